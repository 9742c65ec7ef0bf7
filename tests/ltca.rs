//! Loaded tooth contact analysis: laws and the example's figures.

use planetwear::contact::hertz::{contact_modulus, line_contact};
use planetwear::contact::iso6336::{iso_stiffness, IsoPair};
use planetwear::contact::ltca::{mesh_ltca, set_ltca, MeshModel, SetModel};
use planetwear::contact::separation::MeshFlanks;
use planetwear::model::gear::{GearSet, MeshKind};
use planetwear::scene::Scene;

#[path = "support/in_phase.rs"]
mod in_phase;

fn example() -> GearSet {
    Scene::example_2004().validate().unwrap()
}

fn per_planet_load(set: &GearSet) -> f64 {
    set.input_torque() / set.sun().base_radius() / set.planet_angles().len() as f64
}

#[test]
fn pair_loads_add_up_to_the_mesh_load_and_stiffness_is_periodic() {
    let set = example();
    let w = per_planet_load(&set);
    for mesh in MeshKind::ALL {
        let model = MeshModel::new(&set, mesh, &MeshFlanks::default());
        let r = mesh_ltca(&set, &model, w, 100);
        let pb = model.path().base_pitch;
        let mut pairs = Vec::new();
        for (i, s) in r.position.iter().enumerate() {
            let (f, k) = model.force(*s, r.transmission_error[i], Some(&mut pairs));
            let sum: f64 = pairs.iter().map(|p| p.force).sum();
            assert!((sum / w - 1.0).abs() < 1e-9, "{mesh:?} sum of pair loads {sum} vs {w}");
            assert!((f / w - 1.0).abs() < 1e-9);
            let (f2, k2) = model.force(s + pb, r.transmission_error[i], None);
            assert!((f2 - f).abs() < 1e-9 * w && (k2 - k).abs() < 1e-9 * k, "not periodic at {s}");
        }
        let nominal: Vec<f64> = r.position.iter().map(|s| model.nominal_mesh_stiffness(*s)).collect();
        let mean = nominal.iter().sum::<f64>() / nominal.len() as f64 / (set.sun().face_width * 1e3) * 1e-6;
        eprintln!(
            "{mesh:?}: loaded contact ratio {:.4}, mean nominal mesh stiffness {mean:.3} N/(mm·µm), TE p-p {:.3} µm",
            r.loaded_contact_ratio(),
            (r.transmission_error.iter().cloned().fold(f64::MIN, f64::max)
                - r.transmission_error.iter().cloned().fold(f64::MAX, f64::min))
                * 1e6
        );
        // The loaded mesh engages before and after the nominal path (tip-corner contact).
        assert!(r.loaded_contact_ratio() > model.path().involute_contact_ratio());
    }
}

#[test]
fn mean_mesh_stiffness_of_the_example_is_inside_the_iso_band() {
    let set = example();
    let model = MeshModel::new(&set, MeshKind::SunPlanet, &MeshFlanks::default());
    let r = mesh_ltca(&set, &model, per_planet_load(&set), 200);
    let width_mm = set.sun().face_width * 1e3;
    let mean = r.mesh_stiffness_nominal.iter().sum::<f64>() / 200.0 / width_mm * 1e-6;
    // ISO 6336-1 for this pair: x = ±0.295 (the thicknesses with the backlash
    // split equally), h_fP = 1.37 m, ε_α = 1.3436.
    let iso = iso_stiffness(&IsoPair {
        z1: 34.0,
        z2: Some(18.0),
        x1: -0.295,
        x2: 0.295,
        helix: 0.0,
        rack_pressure_angle: 21.3f64.to_radians(),
        rack_dedendum: 1.37,
        contact_ratio: model.path().nominal_contact_ratio(),
    });
    let ratio = mean / iso.mesh;
    eprintln!("mean mesh stiffness {mean:.3} N/(mm·µm), ISO c_γα {:.3}, ratio {ratio:.3}", iso.mesh);
    assert!(ratio > 0.7 && ratio < 1.3, "ratio to ISO {ratio}");
}

#[test]
fn hertz_pressure_of_a_pair_matches_the_closed_form() {
    let set = example();
    let model = MeshModel::new(&set, MeshKind::SunPlanet, &MeshFlanks::default());
    let w = per_planet_load(&set);
    let r = mesh_ltca(&set, &model, w, 200);
    let p = model.path();
    // The pair through the pitch point carries the whole load (single-pair zone).
    let i = r
        .pair_path_position
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - p.pitch_point()).abs().total_cmp(&(b.1 - p.pitch_point()).abs()))
        .unwrap()
        .0;
    let s = r.pair_path_position[i];
    let load = r.pair_path_load[i];
    assert!((load / w - 1.0).abs() < 1e-9, "single pair at pitch point carries {load} of {w}");
    let e = 207e9 / (2.0 * (1.0 - 0.09));
    let rho1 = s;
    let rho2 = p.tangency_distance - s;
    let r_eq = rho1 * rho2 / (rho1 + rho2);
    let wl = load / 0.030;
    let b = (4.0 * wl * r_eq / (std::f64::consts::PI * e)).sqrt();
    let p0 = 2.0 * wl / (std::f64::consts::PI * b);
    assert!((r.pair_path_half_width[i] / b - 1.0).abs() < 1e-9);
    assert!((r.pair_path_peak_pressure[i] / p0 - 1.0).abs() < 1e-9);
    let c = line_contact(wl, rho1, rho2, false, contact_modulus(207e9, 0.3, 207e9, 0.3));
    assert!((c.peak_pressure / p0 - 1.0).abs() < 1e-12);
    eprintln!("pitch point: b = {:.2} µm, p0 = {:.0} MPa", b * 1e6, p0 * 1e-6);
}

#[test]
fn planets_share_the_load_equally_on_average_and_loads_add_up() {
    let set = example();
    let model = SetModel::new(&set);
    let r = set_ltca(&set, &model, 100);
    let total = set.input_torque() / set.sun().base_radius();
    for i in 0..r.travel.len() {
        let sum: f64 = r.planet_load.iter().map(|p| p[i]).sum();
        assert!((sum / total - 1.0).abs() < 1e-9, "planet loads add to {sum} of {total}");
        // Planets 0 and 2 (and 1 and 3) mesh in phase: Z_sun·90°/360° = 8.5.
        assert!((r.planet_load[0][i] - r.planet_load[2][i]).abs() < 1e-6 * total);
        assert!((r.planet_load[1][i] - r.planet_load[3][i]).abs() < 1e-6 * total);
    }
    for m in &r.planet_mean_load {
        assert!((m / (total / 4.0) - 1.0).abs() < 2e-3, "mean planet load {m}");
    }
    eprintln!("load sharing factor {:.4}", r.load_sharing_factor);
}

#[test]
fn in_phase_planets_share_the_load_equally_at_every_position() {
    // Z_sun / n = 36 / 4 and Z_ring / n = 72 / 4 are integers: all four
    // sun meshes (and all four ring meshes) are in phase.
    let set = in_phase::in_phase_scene().validate().unwrap_or_else(|e| panic!("{e}"));
    let r = set_ltca(&set, &SetModel::new(&set), 50);
    let total = set.input_torque() / set.sun().base_radius();
    for i in 0..r.travel.len() {
        for p in &r.planet_load {
            assert!((p[i] / (total / 4.0) - 1.0).abs() < 1e-9, "planet load {} at {i}", p[i]);
        }
    }
    assert!((r.load_sharing_factor - 1.0).abs() < 1e-9);
}

mod deviations_and_slices {
    use super::*;
    use planetwear::geometry::profile::ProfileDeviation;

    fn uniform(depth: f64) -> ProfileDeviation {
        ProfileDeviation::new(vec![0.0, 1.0], vec![depth, depth])
    }

    #[test]
    fn a_profile_deviation_adds_to_the_separation_and_to_the_static_te() {
        let set = example();
        let worn = MeshFlanks { gear1_drive: uniform(5e-6), ..MeshFlanks::default() };
        let m0 = MeshModel::new(&set, MeshKind::SunPlanet, &MeshFlanks::default());
        let m1 = MeshModel::new(&set, MeshKind::SunPlanet, &worn);
        let p = m0.path().clone();
        for i in 1..20 {
            let s = p.start + (p.end - p.start) * i as f64 / 20.0;
            let dg = m1.separation.drive.at(s) - m0.separation.drive.at(s);
            assert!((dg - 5e-6).abs() < 2e-8, "separation change {dg} at {s}");
            // The back flank is untouched.
            let s_back = 0.5 * (m0.separation.back_range.0 + m0.separation.back_range.1);
            assert!((m1.separation.back.at(s_back) - m0.separation.back.at(s_back)).abs() < 1e-9);
        }
        // In the single-pair zone the loaded TE moves by the deviation exactly.
        let w = per_planet_load(&set);
        let s = p.pitch_point();
        let te0 = m0.approach_for(s, w);
        let te1 = m1.approach_for(s, w);
        assert!((te1 - te0 - 5e-6).abs() < 2e-8, "TE change {}", te1 - te0);
    }

    #[test]
    fn equal_slices_reproduce_the_whole_face_and_a_worn_slice_unloads() {
        let set = example();
        let w = per_planet_load(&set);
        let whole = MeshModel::new(&set, MeshKind::SunPlanet, &MeshFlanks::default());
        let three = MeshModel::sliced(&set, MeshKind::SunPlanet, &vec![MeshFlanks::default(); 3]);
        let s = whole.path().pitch_point();
        let d1 = whole.approach_for(s, w);
        let d3 = three.approach_for(s, w);
        assert!((d1 - d3).abs() < 1e-12 * d1.abs().max(1e-9), "{d1} vs {d3}");
        // Slice 0 worn by e = 2 µm: in the single-pair zone the two halves
        // carry k/2·δ and k/2·(δ − e), so the unworn half's line load is the
        // mean line load times 1 + k·e/(2F).
        let worn = MeshFlanks { gear1_drive: uniform(2e-6), ..MeshFlanks::default() };
        let two = MeshModel::sliced(&set, MeshKind::SunPlanet, &[worn, MeshFlanks::default()]);
        let d = two.approach_for(s, w);
        let mut pairs = Vec::new();
        let (f, _) = two.force(s, d, Some(&mut pairs));
        assert!((f / w - 1.0).abs() < 1e-9);
        let loaded = pairs.iter().find(|p| p.force > 0.0).unwrap();
        let mean_line = loaded.force / set.sun().face_width;
        let expected = 1.0 + two.stiffness.at(loaded.position) * 2e-6 / (2.0 * w);
        // 1e-5: the model interpolates k from its 400-per-pitch table.
        assert!(
            (loaded.max_line_load / mean_line / expected - 1.0).abs() < 1e-5,
            "{} vs {}",
            loaded.max_line_load / mean_line,
            expected
        );
    }
}

/// The single-slice path of `force_with_derivatives` (the dynamic model's event
/// evaluation, read from the interleaved tables) gives bit for bit what the general
/// slice-by-slice path gives: on worn flanks with the example's relieved edges, in drive
/// contact, in the backlash and in back contact, with pairs entering and leaving the tables.
#[test]
fn the_single_slice_event_path_is_the_general_path_bit_for_bit() {
    use planetwear::geometry::profile::ProfileDeviation;
    let set = example();
    let w = per_planet_load(&set);
    let wear = |a: f64, b: f64| ProfileDeviation::new(vec![0.0, 0.3, 0.7, 1.0], vec![a, 0.0, b, 0.5 * a]);
    let worn = MeshFlanks {
        gear1_drive: wear(4e-6, 1e-6),
        gear1_back: wear(2e-6, 3e-6),
        gear2_drive: wear(1e-6, 2e-6),
        gear2_back: wear(3e-6, 0.5e-6),
    };
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for kind in [MeshKind::SunPlanet, MeshKind::RingPlanet] {
        for flanks in [&MeshFlanks::default(), &worn] {
            let m = MeshModel::new(&set, kind, flanks);
            let p = m.path().clone();
            let backlash = m.separation.normal_backlash;
            let slots = m.event_slots();
            let (mut fast, mut general) = (vec![0.0; 2 * slots], vec![0.0; 2 * slots]);
            let mut compared = [0usize; 3];
            for i in 0..=1200 {
                // Four base pitches around the path: pairs enter and leave the tables.
                let s = p.start + (i as f64 / 1200.0 * 4.0 - 1.5) * p.base_pitch;
                let d = m.approach_for(s.clamp(p.start, p.end), w);
                for delta in [d, 0.3 * d, 0.0, -0.5 * backlash, -backlash - d, -backlash - 0.2 * d, 2.0 * d] {
                    let a = m.force_with_derivatives(s, delta, &mut fast);
                    let b = m.force_with_derivatives_sliced(s, delta, &mut general);
                    let law = |l: &planetwear::contact::ltca::MeshLaw| {
                        bits(&[l.force, l.approach_stiffness, l.position_derivative, l.peak_pair_force])
                    };
                    assert_eq!(law(&a), law(&b), "{kind:?} at s = {s}, δ = {delta}: {a:?} vs {b:?}");
                    assert_eq!(bits(&fast), bits(&general), "{kind:?} events at s = {s}, δ = {delta}");
                    // Without event slots (the hot path's fallback) the law is the same.
                    let c = m.force_with_derivatives(s, delta, &mut []);
                    assert_eq!(law(&a), law(&c));
                    compared[(a.force > 0.0) as usize + 2 * (a.force < 0.0) as usize] += 1;
                }
            }
            // Every regime was seen: open, drive contact, back contact.
            assert!(compared.iter().all(|&n| n > 100), "{kind:?}: {compared:?}");
        }
    }
    // Far outside the tables and at non-finite input the two paths still agree.
    let m = MeshModel::new(&set, MeshKind::SunPlanet, &worn);
    let slots = m.event_slots();
    let (mut fast, mut general) = (vec![0.0; 2 * slots], vec![0.0; 2 * slots]);
    for s in [1e20, -1e20, 1e300, f64::NAN, f64::INFINITY] {
        for delta in [1e-5, -1e-3, f64::NAN] {
            let a = m.force_with_derivatives(s, delta, &mut fast);
            let b = m.force_with_derivatives_sliced(s, delta, &mut general);
            assert_eq!(
                [a.force, a.approach_stiffness, a.position_derivative, a.peak_pair_force].map(f64::to_bits),
                [b.force, b.approach_stiffness, b.position_derivative, b.peak_pair_force].map(f64::to_bits),
                "s = {s}, δ = {delta}"
            );
            assert_eq!(bits(&fast), bits(&general), "events at s = {s}, δ = {delta}");
        }
    }
}

/// The pair model's derivatives of its tangent stiffness (what Rayleigh
/// damping's tangent reads) are those of the law it interpolates: at 400
/// positions over a cycle of each mesh, under the nominal approach and twice
/// it, ∂K_t/∂s equals the central difference of `force_tangents`' stiffness
/// (10 nm) to 1e-6 of the largest |∂K_t/∂s| met, and ∂K_t/∂δ is 0 as the
/// difference in δ is, wherever the two one-sided differences agree (no
/// table node or contact switch within the step).
#[test]
fn the_pair_models_stiffness_derivatives_are_its_laws() {
    let set = example();
    let w = per_planet_load(&set);
    for mesh in MeshKind::ALL {
        let model = MeshModel::new(&set, mesh, &MeshFlanks::default());
        let p = model.path().clone();
        let reach = model.approach_for(p.start, w);
        let k = |s: f64, d: f64| model.force_tangents(s, d).approach_stiffness;
        let (mut smooth, mut largest, mut worst_s, mut worst_d) = (0, 0.0_f64, 0.0_f64, 0.0_f64);
        for j in 0..400 {
            for delta in [reach, 2.0 * reach] {
                let s = p.start + p.base_pitch * (j as f64 + 0.37) / 400.0;
                let (hs, hd) = (1e-8, 1e-4 * reach);
                let (left, right) =
                    ((k(s, delta) - k(s - hs, delta)) / hs, (k(s + hs, delta) - k(s, delta)) / hs);
                let (down, up) =
                    ((k(s, delta) - k(s, delta - hd)) / hd, (k(s, delta + hd) - k(s, delta)) / hd);
                if (left - right).abs() > 1e-6 * left.abs().max(right.abs()).max(1.0) || down != up {
                    continue;
                }
                smooth += 1;
                let (d_delta, d_s) = model.stiffness_derivatives(s, delta);
                largest = largest.max(d_s.abs());
                worst_s = worst_s.max((d_s - 0.5 * (left + right)).abs());
                worst_d = worst_d.max((d_delta - 0.5 * (down + up)).abs());
            }
        }
        eprintln!("{mesh:?}: {smooth} smooth points, |∂K/∂s| ≤ {largest:.3e} N/m², worst {worst_s:.2e}, ∂K/∂δ {worst_d:.2e}");
        assert!(smooth > 700, "{mesh:?}: only {smooth} of 800 points away from a node");
        assert!(largest > 0.0 && worst_s <= 1e-6 * largest, "{mesh:?}: ∂K/∂s off by {worst_s}");
        assert_eq!(worst_d, 0.0, "{mesh:?}: ∂K/∂δ");
    }
}
