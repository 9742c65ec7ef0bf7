//! Archard wear: the laws of one passage, one cycle and one update, and the
//! example's figures through six updates.
//!
//! The cases run on the uncalibrated reading of the example
//! (`Scene::example_2004_annulus`), whose figures they pin; the calibrated
//! example's own laws and figures: tests/calibrated_example.rs.

use planetwear::contact::hertz::LineContact;
use planetwear::model::gear::{GearSet, Member, MeshKind};
use planetwear::model::mesh::PathOfContact;
use planetwear::scene::Scene;
use planetwear::wear::archard::{
    passage_wear, sliding_map, Band, CycleWear, Limit, Stop, WearError, WearSettings, WearingFlanks,
};
use planetwear::wear::flank::{contact_rolls, cycles_per_input_revolution, involute_arc, Flank, UpdateEnd};
use planetwear::wear::state::WornState;
use planetwear::wear::stepper::WearModel;
use proptest::prelude::*;

#[path = "support/in_phase.rs"]
mod in_phase;

fn example() -> GearSet {
    Scene::example_2004_annulus().validate().unwrap()
}

/// A set whose planets all mesh in phase (Z_sun/n and Z_ring/n integers):
/// every planet carries exactly a quarter of the load at every position,
/// so in the single-pair zone a pair's load is constant (tests/ltca.rs).
fn in_phase() -> GearSet {
    in_phase::in_phase_scene().validate().unwrap_or_else(|e| panic!("{e}"))
}

fn cycle_of(set: &GearSet, settings: WearSettings) -> (WearModel, WornState, CycleWear) {
    let model = WearModel::new(set, settings).unwrap();
    let state = model.unworn();
    let cycle = model.cycle(&state).unwrap();
    (model, state, cycle)
}

fn max_of(v: &[f64]) -> f64 {
    v.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
}

/// Linear interpolation on an increasing grid.
fn interp(x: &[f64], y: &[f64], at: f64) -> f64 {
    planetwear::geometry::profile::interpolate(x, y, at)
}

#[test]
fn cycles_per_input_revolution_follow_from_the_carrier_frame() {
    // docs/MODEL.md §4.5, carrier held, sun driven: sun n, planet Z_s/Z_p, ring n·Z_s/Z_r.
    let c = cycles_per_input_revolution(&example());
    assert!((c.sun - 4.0).abs() < 1e-12, "{c:?}");
    assert!((c.planet - 34.0 / 18.0).abs() < 1e-12, "{c:?}");
    assert!((c.ring - 4.0 * 34.0 / 70.0).abs() < 1e-12, "{c:?}");
    // Ring held, sun driven: the carrier turns Z_s/(Z_s + Z_r) per sun turn,
    // the sun Z_r/(Z_s + Z_r) relative to it.
    let mut s = Scene::example_2004_annulus();
    s.operation.held = Member::Ring;
    s.operation.input = Member::Sun;
    let c = cycles_per_input_revolution(&s.validate().unwrap());
    let rel = 70.0 / 104.0;
    assert!((c.sun - 4.0 * rel).abs() < 1e-12, "{c:?}");
    assert!((c.planet - 34.0 * rel / 18.0).abs() < 1e-12, "{c:?}");
    assert!((c.ring - 4.0 * 34.0 * rel / 70.0).abs() < 1e-12, "{c:?}");
}

#[test]
fn settings_are_checked_and_the_refusal_names_the_setting() {
    let ok = WearSettings::default();
    assert_eq!(ok.validate(), Ok(()));
    let cases: Vec<(&str, WearSettings)> = vec![
        ("archard_coefficient", WearSettings { archard_coefficient: -1e-18, ..ok }),
        ("archard_coefficient", WearSettings { archard_coefficient: f64::NAN, ..ok }),
        ("positions", WearSettings { positions: 3, ..ok }),
        ("profile_points", WearSettings { profile_points: 1, ..ok }),
        ("face_slices", WearSettings { face_slices: 0, ..ok }),
        ("update_depth", WearSettings { update_depth: 0.0, ..ok }),
        ("total_depth", WearSettings { total_depth: 1e-6, ..ok }),
        (
            "wearing",
            WearSettings {
                wearing: WearingFlanks {
                    sun_drive: false,
                    planet_sun_side: false,
                    planet_ring_side: false,
                    ring_drive: false,
                },
                ..ok
            },
        ),
    ];
    for (name, s) in cases {
        match WearModel::new(&example(), s) {
            Err(e @ WearError::InvalidSetting { name: n, .. }) => {
                assert_eq!(n, name);
                assert!(e.to_string().contains(name) && e.to_string().contains("allowed"), "{e}");
            }
            other => panic!("{name}: expected a refusal, got {:?}", other.map(|_| ())),
        }
    }
}

#[test]
fn corner_contact_touches_the_mating_flank_above_its_start_of_active_profile() {
    // Before the path the mating tip corner (fixed on gear 2) slides down
    // gear 1's flank at the sliding speed: dσ1/ds = ξ1 − ξ2 at the start
    // (relative velocity of the corner, (v1 − v2)/(ω1 r_b1)).
    let set = example();
    for mesh in MeshKind::ALL {
        let p = PathOfContact::new(&set, mesh);
        let (a0, b0) = contact_rolls(&p, p.start);
        assert!((a0 - p.roll_1(p.start)).abs() < 1e-15 && (b0 - p.roll_2(p.start)).abs() < 1e-15);
        let h = 1e-7;
        let (a1, b1) = contact_rolls(&p, p.start - h);
        assert_eq!(b1, b0, "{mesh:?}: gear 2's corner stays put");
        let rate = (involute_arc(p.base_radius_1, a1) - involute_arc(p.base_radius_1, a0)) / -h;
        let expected = a0 - b0;
        assert!((rate / expected - 1.0).abs() < 1e-3, "{mesh:?}: dσ1/ds {rate} vs ξ1 − ξ2 {expected}");
        assert!(a1 > a0, "{mesh:?}: corner contact lies above gear 1's start of active profile");
        // After the path gear 1's corner stays put and gear 2 is touched
        // above its own lowest contact point (external) / deeper (ring).
        let (c0, d0) = contact_rolls(&p, p.end);
        let (c1, d1) = contact_rolls(&p, p.end + h);
        assert_eq!(c1, c0);
        let rate2 = (involute_arc(p.base_radius_2, d1) - involute_arc(p.base_radius_2, d0)) / h;
        // Gear 1's corner moves relative to gear 2 at (ξ2 − ξ1) along the
        // common tangent, along which gear 2's arc runs backwards on the
        // external pair and forwards on the ring: dσ2/ds = ξ1 − ξ2, resp. ξ2 − ξ1.
        let sign = if mesh == MeshKind::SunPlanet { 1.0 } else { -1.0 };
        let expected2 = sign * (p.roll_1(p.end) - p.roll_2(p.end));
        assert!((rate2 / expected2 - 1.0).abs() < 1e-3, "{mesh:?}: dσ2/ds {rate2} vs {expected2}");
    }
}

/// A band moving over a flank at `v_self` per step while the mate slides
/// by `|v_self − v_mate|` per step, with a constant contact.
fn constant_band(v_self: f64, v_mate: f64, b: f64, p0: f64, steps: usize) -> (Vec<Band>, Vec<f64>) {
    let contact = LineContact { half_width: b, peak_pressure: p0 };
    let bands = (0..=steps).map(|r| Band { centre: v_self * r as f64, contact }).collect();
    (bands, vec![(v_self - v_mate).abs(); steps])
}

#[test]
fn sliding_distance_and_wear_per_passage_of_a_constant_band_are_flodin_and_andersson() {
    // s = 2b|1 − v_mate/v_self| exactly (the in-band fraction is exact for a
    // linear motion); Δh = k·w·|v_self − v_mate|/v_self to the trapezoid's
    // error, which the square-root edges of the elliptic pressure make
    // O((v_self/2b)^1.5): below 4 % with 10 steps per band width 2b, below
    // 1.5 % with 20, below 0.6 % with 40.
    let (b, p0, k) = (100e-6, 1.0e9, 1e-18);
    let w = std::f64::consts::PI * p0 * b / 2.0;
    for (v_self, v_mate, tolerance) in [
        (20e-6, 8e-6, 0.04),
        (20e-6, 50e-6, 0.04),
        (10e-6, 4e-6, 0.015),
        (10e-6, 30e-6, 0.015),
        (5e-6, 2e-6, 0.006),
    ] {
        let (bands, slip) = constant_band(v_self, v_mate, b, p0, (8e-3 / v_self) as usize);
        let arc: Vec<f64> = (0..40).map(|i| 2e-3 + 0.1e-3 * i as f64 + 1.234e-6).collect();
        let pass = passage_wear(&arc, &bands, &slip, k);
        let ratio = (1.0 - v_mate / v_self).abs();
        for g in 0..arc.len() {
            let s = pass.sliding[g];
            assert!((s / (2.0 * b * ratio) - 1.0).abs() < 1e-9, "sliding {s} vs {}", 2.0 * b * ratio);
            let dh = pass.wear[g];
            let expected = k * w * ratio;
            assert!(
                (dh / expected - 1.0).abs() < tolerance,
                "v {v_self}/{v_mate}: wear {dh} vs {expected} ({} steps per band)",
                2.0 * b / v_self
            );
        }
        // The per-step map adds up to the passage.
        let map = sliding_map(&arc, &bands, &slip);
        let sum: f64 = map.iter().map(|row| row[7]).sum();
        assert!((sum - pass.sliding[7]).abs() < 1e-15);
    }
    // Pure rolling (the pitch point): no sliding, no wear.
    let (bands, slip) = constant_band(20e-6, 20e-6, b, p0, 400);
    let pass = passage_wear(&[3e-3], &bands, &slip, k);
    assert_eq!((pass.wear[0], pass.sliding[0]), (0.0, 0.0));
    // A tip corner holds its band (v_self = 0): all the slip goes by it.
    let contact = LineContact { half_width: b, peak_pressure: p0 };
    let bands: Vec<Band> = (0..=50).map(|_| Band { centre: 1e-3, contact }).collect();
    let pass = passage_wear(&[1e-3], &bands, &[3e-6; 50], k);
    assert!((pass.sliding[0] - 150e-6).abs() < 1e-18);
    assert!((pass.wear[0] - k * p0 * 150e-6).abs() < 1e-12 * k * p0 * 150e-6);
}

/// For each grid point crossed once by the band on the involute path, away
/// from the pitch point: (roll, sliding / 2b̄|1 − v_mate/v_self|,
/// wear / k·w̄·|1 − v_mate/v_self|), b̄ and w̄ averaged over the point's time in the band.
fn flodin_ratios(c: &CycleWear, flank: Flank, k: f64, steady: f64) -> Vec<(f64, f64, f64)> {
    let (mesh, gear1) = flank.drive_mesh().unwrap();
    let fw = c.flank(flank, 0).unwrap();
    let mp = c.mesh(mesh).unwrap();
    let (own, mate) = if gear1 { (&mp.roll_gear1, &mp.roll_gear2) } else { (&mp.roll_gear2, &mp.roll_gear1) };
    let map = fw.sliding_map(0);
    let bands = &fw.bands[0];
    let mut out = Vec::new();
    for g in 0..fw.roll.len() {
        let xi = fw.roll[g];
        let crossings: Vec<usize> =
            (0..own.len() - 1).filter(|r| (own[*r] - xi) * (own[r + 1] - xi) < 0.0).collect();
        if crossings.len() != 1 {
            continue;
        }
        let r = crossings[0];
        let t = (xi - own[r]) / (own[r + 1] - own[r]);
        let ratio = (mate[r] + t * (mate[r + 1] - mate[r])) / xi;
        if (1.0 - ratio).abs() < 0.25 {
            continue;
        }
        // Only points the band passes once: it must move one way while the
        // point is inside it (not near a corner contact's turning point).
        let inside: Vec<usize> = (0..map.len()).filter(|q| map[*q][g] > 0.0).collect();
        let direction = |q: usize| {
            let d = own[q + 1] - own[q];
            if d > 0.0 {
                1
            } else if d < 0.0 {
                -1
            } else {
                0
            }
        };
        if inside.is_empty()
            || inside.iter().any(|q| direction(*q) == 0 || direction(*q) != direction(inside[0]))
        {
            continue;
        }
        // The closed form is for a steady band: skip points passed while
        // the load moves between pairs (b changes by more than `steady`).
        let widths: Vec<f64> =
            (inside[0]..=inside[inside.len() - 1] + 1).map(|q| bands[q].contact.half_width).collect();
        if max_of(&widths) > steady * widths.iter().cloned().fold(f64::INFINITY, f64::min) {
            continue;
        }
        let (mut total, mut w) = (0.0, 0.0);
        for (q, row) in map.iter().enumerate() {
            let s = row[g];
            total += s;
            let wl = |band: &Band| {
                std::f64::consts::PI * band.contact.peak_pressure * band.contact.half_width / 2.0
            };
            w += s * 0.5 * (wl(&bands[q]) + wl(&bands[q + 1]));
        }
        if total == 0.0 {
            continue;
        }
        // The band travels b_in + b_out while the point is inside: b where
        // the point enters and where it leaves (linear within a step).
        let (qa, qb) = (inside[0], inside[inside.len() - 1]);
        let f_in = map[qa][g] / fw.slip[qa];
        let f_out = map[qb][g] / fw.slip[qb];
        let half = |q: usize, t: f64| {
            bands[q].contact.half_width + t * (bands[q + 1].contact.half_width - bands[q].contact.half_width)
        };
        let (b_in, b_out) = (half(qa, 1.0 - f_in), half(qb, f_out));
        let w = w / total;
        let sliding = fw.sliding[0][g] / ((b_in + b_out) * (1.0 - ratio).abs());
        let wear = fw.wear_per_planet[0][g] / (k * w * (1.0 - ratio).abs());
        out.push((xi, sliding, wear));
    }
    out
}

#[test]
fn sliding_distance_and_wear_per_passage_on_the_gears_match_the_closed_form() {
    // In-phase planets, R = 800: at points passed by a steady band (b
    // changes by under 6 % during the passage, i.e. not while the load moves
    // between pairs) the sliding distance, with b_in + b_out where the point
    // enters and leaves the band, is within 1.5 % of 2b|1 − v_mate/v_self|,
    // and the wear within 1 % of k·w̄·|v_i − v_j|/v_i (w̄ the line load over
    // the passage; the trapezoid's error is small with ~40–80 steps per band).
    let fine = WearSettings { positions: 800, ..WearSettings::default() };
    let (_, _, c) = cycle_of(&in_phase(), fine);
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let r = flodin_ratios(&c, flank, fine.archard_coefficient, 1.06);
        assert!(r.len() >= 10, "{flank:?}: only {} points checked", r.len());
        for (xi, s, h) in &r {
            assert!((s - 1.0).abs() < 0.015, "{flank:?} at {:.2}°: sliding ratio {s}", xi.to_degrees());
            assert!((h - 1.0).abs() < 0.01, "{flank:?} at {:.2}°: wear ratio {h}", xi.to_degrees());
        }
    }
    // The example at the default R = 200, points whose band changes by
    // under 20 % during the passage (its planets' shares move the load all
    // through the cycle): a band spans only 10–20 steps, whose trapezoid
    // loses up to 4 % of the wear at the band's square-root edges: sliding
    // within 3 %, wear within 6 %.
    let settings = WearSettings::default();
    let (_, _, c) = cycle_of(&example(), settings);
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let r = flodin_ratios(&c, flank, settings.archard_coefficient, 1.2);
        assert!(r.len() >= 10, "{flank:?}: only {} points checked", r.len());
        for (xi, s, h) in r {
            assert!((s - 1.0).abs() < 0.03, "{flank:?} at {:.2}°: sliding ratio {s}", xi.to_degrees());
            assert!((h - 1.0).abs() < 0.06, "{flank:?} at {:.2}°: wear ratio {h}", xi.to_degrees());
        }
    }
}

#[test]
fn almost_no_wear_at_the_pitch_point() {
    // No sliding at the pitch point: the wear there comes only from the band
    // width around it, under 3 % of the flank's largest, and the wear
    // profile's minimum sits within one grid spacing of the pitch point.
    let set = example();
    let (_, _, c) = cycle_of(&set, WearSettings::default());
    let p = PathOfContact::new(&set, MeshKind::SunPlanet);
    for (flank, pitch) in
        [(Flank::SunDrive, p.roll_1(p.pitch_point())), (Flank::PlanetSunSide, p.roll_2(p.pitch_point()))]
    {
        let fw = c.flank(flank, 0).unwrap();
        let at_pitch = interp(&fw.roll, &fw.wear_per_cycle, pitch);
        let max = max_of(&fw.wear_per_cycle);
        assert!(at_pitch < 0.03 * max, "{flank:?}: {at_pitch:e} at the pitch point, max {max:e}");
        let (i_min, _) = fw.wear_per_cycle.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1)).unwrap();
        let spacing = fw.roll[1] - fw.roll[0];
        assert!(
            (fw.roll[i_min] - pitch).abs() <= spacing,
            "{flank:?}: least wear at {:.2}°, pitch point {:.2}°",
            fw.roll[i_min].to_degrees(),
            pitch.to_degrees()
        );
    }
}

#[test]
fn wear_is_linear_in_the_archard_coefficient_and_in_the_load() {
    let set = in_phase();
    let base = WearSettings { profile_points: 200, ..WearSettings::default() };
    let (_, _, c1) = cycle_of(&set, base);
    let (_, _, c3) =
        cycle_of(&set, WearSettings { archard_coefficient: 3.0 * base.archard_coefficient, ..base });
    for (a, b) in c1.flanks.iter().zip(&c3.flanks) {
        for (x, y) in a.wear_per_cycle.iter().zip(&b.wear_per_cycle) {
            assert!((y - 3.0 * x).abs() <= 1e-12 * y.abs(), "{x:e} ×3 ≠ {y:e}");
        }
    }
    // Twice the torque at fixed geometry: in the single-pair zone the pair
    // carries the planet's load exactly, so the wear doubles there (to 2 %:
    // b grows by √2, which moves the trapezoid's error).
    let mut heavy_scene = in_phase::in_phase_scene();
    heavy_scene.operation.input_torque_nm *= 2.0;
    let heavy = heavy_scene.validate().unwrap();
    assert_eq!(heavy.input_torque(), 2.0 * set.input_torque());
    let (_, _, c2) = cycle_of(&heavy, base);
    let p = PathOfContact::new(&set, MeshKind::SunPlanet);
    // The loaded single-pair zone of both loads: the pair carries the
    // planet's whole load (the heavier load's zone is the shorter).
    let zone = |c: &CycleWear, load: f64| {
        let mp = c.mesh(MeshKind::SunPlanet).unwrap();
        let alone: Vec<f64> = mp
            .position
            .iter()
            .zip(&mp.pair_load[0])
            .filter(|(_, f)| (**f / load - 1.0).abs() < 1e-9)
            .map(|(s, _)| *s)
            .collect();
        (alone[0], alone[alone.len() - 1])
    };
    let (a0, a1) = zone(&c1, set.mesh_load_per_planet());
    let (b0, b1) = zone(&c2, heavy.mesh_load_per_planet());
    let single = (a0.max(b0), a1.min(b1));
    assert!(single.1 - single.0 > 1.5e-3, "single-pair zone {single:?}");
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let (a, b) = (c1.flank(flank, 0).unwrap(), c2.flank(flank, 0).unwrap());
        let mut checked = 0;
        for g in 0..a.roll.len() {
            // Points whose band passage lies inside the single-pair zone.
            let s = match flank {
                Flank::SunDrive => a.roll[g] * p.base_radius_1,
                _ => p.tangency_distance - a.roll[g] * p.base_radius_2,
            };
            // The point is inside the band while the contact is within
            // ±b/ξ of it (b ≈ 0.14 mm at twice the load).
            let margin = 0.15e-3 / a.roll[g];
            if s < single.0 + margin || s > single.1 - margin {
                continue;
            }
            if (s - p.pitch_point()).abs() < 1e-3 {
                continue;
            }
            checked += 1;
            let ratio = b.wear_per_cycle[g] / a.wear_per_cycle[g];
            assert!((ratio - 2.0).abs() < 0.04, "{flank:?} at {:.2}°: ratio {ratio}", a.roll[g].to_degrees());
        }
        assert!(checked >= 4, "{flank:?}: {checked} points checked");
    }
}

#[test]
fn the_two_flanks_wear_in_the_inverse_ratio_of_their_rolling_speeds() {
    // Δh_1/Δh_2 = v_2/v_1 at the same contact point, where both flanks see
    // the same load and the same sliding. In-phase planets, R = 800: at
    // contact points whose load is linear over the band's passage (±0.4 mm;
    // a linear change averages out over both centred windows) within 1.5 %.
    // The example at R = 200, every contact point crossed once away from the
    // pitch point: within 6 % (its planets' shares bend the load within a
    // passage, and the two flanks' windows differ in length).
    for (set, positions, linear_only, tolerance) in
        [(in_phase(), 800, true, 0.015), (example(), 200, false, 0.06)]
    {
        let (_, _, c) = cycle_of(&set, WearSettings { positions, ..WearSettings::default() });
        let p = PathOfContact::new(&set, MeshKind::SunPlanet);
        let sun = c.flank(Flank::SunDrive, 0).unwrap();
        let planet = c.flank(Flank::PlanetSunSide, 0).unwrap();
        let mp = c.mesh(MeshKind::SunPlanet).unwrap();
        // Sun points below the first contact and planet points below the
        // last are passed twice (corner contact, then the involute); the tip
        // corners hold the band in corner contact.
        let (sun_twice, planet_twice) = (mp.roll_gear1[0], mp.roll_gear2[mp.roll_gear2.len() - 1]);
        let mut checked = 0;
        for i in 0..=60 {
            let s = p.start + 0.3e-3 + (p.end - p.start - 0.6e-3) * i as f64 / 60.0;
            let (x1, x2) = (p.roll_1(s), p.roll_2(s));
            if (s - p.pitch_point()).abs() < 0.8e-3 || x1 < sun_twice + 0.01 || x2 < planet_twice + 0.01 {
                continue;
            }
            let window: Vec<f64> = (0..=20)
                .map(|k| interp(&mp.position, &mp.pair_load[0], s - 0.4e-3 + 0.04e-3 * k as f64))
                .collect();
            let bend = (0..=20)
                .map(|k| (window[k] - (window[0] + (window[20] - window[0]) * k as f64 / 20.0)).abs())
                .fold(0.0, f64::max);
            if linear_only && bend > 0.005 * window[10] {
                continue;
            }
            let h1 = interp(&sun.roll, &sun.wear_per_cycle, x1);
            let h2 = interp(&planet.roll, &planet.wear_per_cycle, x2);
            let expected = x2 / x1; // v2/v1 = ω2ρ2/(ω1ρ1) = ξ2/ξ1
            checked += 1;
            assert!(
                (h1 / h2 / expected - 1.0).abs() < tolerance,
                "{}: at s = {:.3} mm Δh1/Δh2 = {} vs v2/v1 = {expected}",
                set.name(),
                s * 1e3,
                h1 / h2
            );
        }
        assert!(checked >= 8, "{}: {checked} contact points checked", set.name());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn wear_and_sliding_are_never_negative(
        centres in prop::collection::vec(-1e-3f64..1e-3, 2..40),
        widths in prop::collection::vec(0f64..2e-4, 40),
        peaks in prop::collection::vec(0f64..3e9, 40),
        slips in prop::collection::vec(0f64..1e-4, 40),
        k in 1e-20f64..1e-15,
    ) {
        let bands: Vec<Band> = centres
            .iter()
            .enumerate()
            .map(|(i, c)| Band { centre: *c, contact: LineContact { half_width: widths[i], peak_pressure: peaks[i] } })
            .collect();
        let arc: Vec<f64> = (0..25).map(|i| -1.2e-3 + 1e-4 * i as f64).collect();
        let pass = passage_wear(&arc, &bands, &slips[..bands.len() - 1], k);
        for (h, s) in pass.wear.iter().zip(&pass.sliding) {
            prop_assert!(*h >= 0.0 && h.is_finite());
            prop_assert!(*s >= 0.0 && s.is_finite());
        }
    }
}

#[test]
fn most_wear_in_the_sun_dedendum_and_the_planet_wears_less() {
    // docs/MODEL.md §4, expected shape: per input revolution the sun wears most
    // in its dedendum (the lowest quarter of its active profile) and more
    // than the planet anywhere. Nothing is negative.
    let set = example();
    let (model, _, c) = cycle_of(&set, WearSettings::default());
    let cpr = model.cycles_per_revolution();
    let sun = c.flank(Flank::SunDrive, 0).unwrap();
    let planet = c.flank(Flank::PlanetSunSide, 0).unwrap();
    for fw in &c.flanks {
        assert!(fw.wear_per_cycle.iter().all(|h| *h >= 0.0));
    }
    let (sun_max, sun_roll) = sun.max_wear();
    let (lo, hi) = (sun.roll[0], sun.roll[sun.roll.len() - 1]);
    assert!(sun_roll < lo + 0.25 * (hi - lo), "sun's deepest wear at {:.2}°", sun_roll.to_degrees());
    let (planet_max, _) = planet.max_wear();
    assert!(
        planet_max * cpr.planet < 0.6 * sun_max * cpr.sun,
        "per revolution: planet {:e}, sun {:e}",
        planet_max * cpr.planet,
        sun_max * cpr.sun
    );
}

#[test]
fn an_update_moves_load_off_the_worn_sun_dedendum() {
    // After one update (2.5 µm at most in the sun dedendum) a pair carries
    // less load while it touches the worn dedendum, and the pairs around it
    // take that load over: in the pair-load path over the sun roll angles
    // worn by more than half the maximum, the mean load drops by over 10 %.
    let set = example();
    let model = WearModel::new(&set, WearSettings::default()).unwrap();
    let s0 = model.unworn();
    let c0 = model.cycle(&s0).unwrap();
    let s1 = model.apply(&s0, &c0, Limit::Update).unwrap();
    let c1 = model.cycle(&s1).unwrap();
    // The worn dedendum: the run of grid points around the deepest one
    // worn by more than half of it.
    let worn = &s1.flanks.sun_drive[0];
    let top = max_of(&worn.depth);
    let i_top = worn.depth.iter().position(|d| *d == top).unwrap();
    let deep = |i: &usize| worn.depth[*i] > 0.5 * top;
    let first = (0..=i_top).rev().take_while(deep).last().unwrap();
    let last = (i_top..worn.depth.len()).take_while(deep).last().unwrap();
    let (lo, hi) = (worn.roll[first], worn.roll[last]);
    let p = PathOfContact::new(&set, MeshKind::SunPlanet);
    let m0 = c0.mesh(MeshKind::SunPlanet).unwrap();
    // Positions (corner contact included) at which the sun is touched in
    // the worn run, and one base pitch later: the pair that shares the load.
    let worn_positions: Vec<f64> = (0..400)
        .map(|i| m0.position[0] + (m0.position[200] - m0.position[0]) * i as f64 / 399.0)
        .filter(|s| {
            let xi = contact_rolls(&p, *s).0;
            xi >= lo && xi <= hi
        })
        .collect();
    let mean_load = |c: &CycleWear, shift: f64| {
        let mp = c.mesh(MeshKind::SunPlanet).unwrap();
        let load = |s: f64| {
            if s < mp.position[0] || s > mp.position[200] {
                0.0
            } else {
                interp(&mp.position, &mp.pair_load[0], s)
            }
        };
        worn_positions.iter().map(|s| load(s + shift)).sum::<f64>() / worn_positions.len() as f64
    };
    let (before, after) = (mean_load(&c0, 0.0), mean_load(&c1, 0.0));
    let pb = p.base_pitch;
    let (mate_before, mate_after) = (mean_load(&c0, pb), mean_load(&c1, pb));
    assert!(after < 0.95 * before, "load on the worn dedendum {before} N → {after} N");
    // The pair one base pitch ahead (on the sun's addendum, hardly worn)
    // takes load over (not all of it: the planets' shares move too).
    let gain = mate_after - mate_before;
    assert!(gain > 0.3 * (before - after), "worn pair loses {} N, the mate gains {gain} N", before - after);
}

#[test]
fn an_update_wears_each_flank_by_its_gears_cycles_up_to_the_update_depth() {
    let set = example();
    let settings = WearSettings::default();
    let model = WearModel::new(&set, settings).unwrap();
    let s0 = model.unworn();
    let c0 = model.cycle(&s0).unwrap();
    let s1 = model.apply(&s0, &c0, Limit::Update).unwrap();
    let u = &s1.history[0];
    let cpr = model.cycles_per_revolution();
    assert_eq!((s1.kappa, u.kappa, u.ended_by), (1, 1, UpdateEnd::UpdateDepth));
    assert!((u.cycles.sun - u.revolutions * cpr.sun).abs() < 1e-9 * u.cycles.sun);
    assert!((u.cycles.planet - u.revolutions * cpr.planet).abs() < 1e-9 * u.cycles.planet);
    assert!((u.cycles.ring - u.revolutions * cpr.ring).abs() < 1e-9 * u.cycles.ring);
    assert_eq!(s1.revolutions, u.revolutions);
    let deepest_new = u.new_wear.iter().map(|e| e.depth).fold(0.0, f64::max);
    assert!((deepest_new / settings.update_depth - 1.0).abs() < 1e-12, "{deepest_new}");
    for fw in &c0.flanks {
        let cycles = u.cycles.of(fw.flank.gear());
        let after = &s1.flanks.get(fw.flank)[0];
        for (g, h) in fw.wear_per_cycle.iter().enumerate() {
            assert!((after.depth[g] - cycles * h).abs() <= 1e-12 * settings.update_depth);
        }
    }
    // The coast flanks and the ring mesh do not wear by default.
    for f in [Flank::SunCoast, Flank::PlanetRingSide, Flank::RingDrive, Flank::RingCoast] {
        assert!(s1.flanks.get(f)[0].is_zero(), "{f:?}");
    }
    // A cycle applies only to the state it was computed on.
    assert!(matches!(model.apply(&s1, &c0, Limit::Update), Err(WearError::CycleMismatch { .. })));
    // A partial update of a given number of revolutions.
    let r = 0.3 * u.revolutions;
    let part = model.run(&s0, Stop::Revolutions(r)).unwrap();
    assert_eq!(part.kappa, 1);
    assert_eq!(part.history[0].ended_by, UpdateEnd::Revolutions);
    assert!((part.revolutions - r).abs() < 1e-9 * r);
    let sun = &part.flanks.sun_drive[0];
    let sun_full = &s1.flanks.sun_drive[0];
    for (a, b) in sun.depth.iter().zip(&sun_full.depth) {
        assert!((a - 0.3 * b).abs() <= 1e-12 * settings.update_depth, "wear is linear in the cycles");
    }
}

#[test]
fn the_stepper_stops_at_the_total_depth() {
    // ε^κ = 2.5 µm, ε_tot = 4 µm: one whole update, then a partial one that
    // ends with the deepest point at exactly 4 µm, then nothing.
    let set = example();
    let settings = WearSettings { total_depth: 4e-6, ..WearSettings::default() };
    let model = WearModel::new(&set, settings).unwrap();
    let s = model.run(&model.unworn(), Stop::TotalWear).unwrap();
    assert_eq!(s.kappa, 2);
    assert_eq!(s.history[1].ended_by, UpdateEnd::TotalDepth);
    assert!((s.deepest().depth / 4e-6 - 1.0).abs() < 1e-9, "{}", s.deepest().depth);
    assert!(matches!(model.step(&s, Limit::Update), Err(WearError::TotalWearReached { .. })));
    assert_eq!(model.run(&s, Stop::Kappa(10)).unwrap(), s);
}

#[test]
fn ring_mesh_wear_on_request() {
    let set = example();
    let settings = WearSettings { wearing: WearingFlanks::both_meshes(), ..WearSettings::default() };
    let (model, state, c) = cycle_of(&set, settings);
    let p = PathOfContact::new(&set, MeshKind::RingPlanet);
    for (flank, pitch) in
        [(Flank::PlanetRingSide, p.roll_1(p.pitch_point())), (Flank::RingDrive, p.roll_2(p.pitch_point()))]
    {
        let fw = c.flank(flank, 0).unwrap();
        let max = max_of(&fw.wear_per_cycle);
        assert!(max > 0.0 && fw.wear_per_cycle.iter().all(|h| *h >= 0.0), "{flank:?}");
        let at_pitch = interp(&fw.roll, &fw.wear_per_cycle, pitch);
        assert!(at_pitch < 0.05 * max, "{flank:?}: {at_pitch:e} at the pitch point, max {max:e}");
    }
    let s1 = model.apply(&state, &c, Limit::Update).unwrap();
    assert!(!s1.flanks.ring_drive[0].is_zero() && !s1.flanks.planet_ring_side[0].is_zero());
    // The sun–planet flanks wear as without the ring (the ring mesh's
    // deviations are still zero in this cycle).
    let (_, _, c_sp) = cycle_of(&set, WearSettings::default());
    let (a, b) = (c.flank(Flank::SunDrive, 0).unwrap(), c_sp.flank(Flank::SunDrive, 0).unwrap());
    assert_eq!(a.wear_per_cycle, b.wear_per_cycle);
}

#[test]
fn equal_face_slices_reproduce_the_profile_grid() {
    // J slices with equal deviations carry the same line load as the whole
    // face: every slice wears as the 2-D grid (to 1e-7 of the largest wear:
    // rounding moves a band edge across a grid point by a hair).
    let set = example();
    let (_, _, c1) = cycle_of(&set, WearSettings::default());
    let (model, s0, c3) = cycle_of(&set, WearSettings { face_slices: 3, ..WearSettings::default() });
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let one = c1.flank(flank, 0).unwrap();
        for j in 0..3 {
            let sl = c3.flank(flank, j).unwrap();
            for (a, b) in one.wear_per_cycle.iter().zip(&sl.wear_per_cycle) {
                assert!((a - b).abs() <= 1e-7 * max_of(&one.wear_per_cycle), "{flank:?} slice {j}");
            }
        }
    }
    assert_eq!(model.apply(&s0, &c3, Limit::Update).unwrap().face_slices(), 3);
    // A state with another slice count is refused by name.
    let other = WearModel::new(&set, WearSettings::default()).unwrap();
    assert_eq!(other.cycle(&s0).unwrap_err(), WearError::SliceCount { state: 3, settings: 1 });
}

#[test]
fn six_updates_of_the_example() {
    // The example's figures (docs/MODEL.md §4: ε^κ = 2.5 µm, six updates).
    // Printed with `cargo test --release --test wear -- --nocapture six_updates`.
    let set = example();
    let settings = WearSettings::default();
    let model = WearModel::new(&set, settings).unwrap();
    let t = std::time::Instant::now();
    let s6 = model.run_to_kappa(&model.unworn(), 6).unwrap();
    let elapsed = t.elapsed();
    assert_eq!(s6.kappa, 6);
    eprintln!("six updates of example-2004 in {elapsed:.2?}");
    eprintln!(
        "{:>2} {:>10} {:>10} {:>10} {:>10} {:>9} | {:>16} {:>16} | {:>8}",
        "κ",
        "C^κ (sun)",
        "planet",
        "ring",
        "input rev",
        "cum. rev",
        "sun max µm @deg",
        "planet max µm @deg",
        "new pl."
    );
    let mut cum = 0.0;
    for u in &s6.history {
        cum += u.revolutions;
        let total = |f: Flank| u.total_wear.iter().find(|e| e.flank == f).copied().unwrap();
        let new = |f: Flank| u.new_wear.iter().find(|e| e.flank == f).copied().unwrap();
        let (sun, planet) = (total(Flank::SunDrive), total(Flank::PlanetSunSide));
        eprintln!(
            "{:>2} {:>10.4e} {:>10.4e} {:>10.4e} {:>10.4e} {:>9.4e} | {:>7.3} @ {:>6.2} {:>7.3} @ {:>6.2} | {:>5.3}@{:.2}",
            u.kappa,
            u.cycles.sun,
            u.cycles.planet,
            u.cycles.ring,
            u.revolutions,
            cum,
            sun.depth * 1e6,
            sun.roll.to_degrees(),
            planet.depth * 1e6,
            planet.roll.to_degrees(),
            new(Flank::PlanetSunSide).depth * 1e6,
            new(Flank::PlanetSunSide).roll.to_degrees(),
        );
        // Each update is a whole one: the sun limits it with 2.5 µm of new wear.
        assert_eq!(u.ended_by, UpdateEnd::UpdateDepth);
        assert_eq!(u.limiting_flank, Flank::SunDrive);
        assert!((new(Flank::SunDrive).depth / 2.5e-6 - 1.0).abs() < 1e-12);
        assert!(planet.depth < sun.depth);
    }
    for flank in [Flank::SunDrive, Flank::PlanetSunSide] {
        let d = &s6.flanks.get(flank)[0];
        let row: Vec<String> = d
            .roll
            .iter()
            .zip(&d.depth)
            .map(|(x, h)| format!("{:.2}°:{:.2}", x.to_degrees(), h * 1e6))
            .collect();
        eprintln!("{} depth [µm] at κ = 6: {}", flank.name(), row.join(" "));
    }
    // The sun's deepest point stays in its dedendum.
    let sun = s6.deepest_on(Flank::SunDrive);
    let (lo, hi) = (s6.flanks.sun_drive[0].roll[0], *s6.flanks.sun_drive[0].roll.last().unwrap());
    assert!(sun.roll < lo + 0.25 * (hi - lo));
}
