//! Quasi-static loaded tooth contact analysis (LTCA).
//!
//! A mesh is a set of tooth pairs, each at its position on the line of
//! action; a pair carries F = k(s)·max(0, δ − g(s)) on its drive flank and
//! −k·max(0, −δ − g_back) on its back flank, δ being the mesh approach along
//! the line of action (zero for perfect rigid involutes in drive contact).
//! Force and tangent stiffness of a mesh are piecewise linear in δ; the
//! equilibria are found by safeguarded Newton iteration on monotone
//! functions, exact to rounding.
//!
//! Whole set (torsional statics, central members on their axes, carrier and
//! output member held): planet n carries F_n through its sun and ring meshes
//! in series, F_sp(δ_s) = F_rp(δ_r) with δ_s + δ_r = u_s (the sun's rotation
//! as a displacement along the line of action), and Σ F_n = n·F with F the
//! tooth force the input torque makes ([`GearSet::mesh_load_per_planet`]).
//! Every tooth sits at its real angular position: the sun mesh of the planet
//! at ψ_n is at travel λ − r_b,sun ψ_n, and its ring mesh follows from the
//! planet's own tooth positions (see [`SetModel::ring_position`]).

use serde::{Deserialize, Serialize};

use crate::contact::hertz::{contact_modulus, line_contact};
use crate::contact::separation::{MeshFlanks, MeshSeparation, NO_CONTACT};
use crate::contact::stiffness::PairStiffness;
use crate::model::gear::{GearKind, GearSet, MeshKind};
use crate::model::mesh::PathOfContact;

/// Contact model of one mesh: separations and pair stiffness on one grid.
///
/// The face width may be cut into J slices across the face, each with its
/// own flank deviations and so its own separation tables; the pair
/// stiffness of the energy method is proportional to the face width, so a
/// slice carries exactly 1/J of it.
#[derive(Clone, Debug)]
pub struct MeshModel {
    /// Separation tables of the first slice (of the whole face when J = 1).
    pub separation: MeshSeparation,
    /// Separation tables of every slice across the face (J ≥ 1).
    pub slices: Vec<MeshSeparation>,
    /// Pair stiffness of the whole face width.
    pub stiffness: PairStiffness,
    face_width: f64,
    drive_k: Vec<f64>,
    back_k: Vec<f64>,
    /// One face slice's tables interleaved per grid point (drive separation, back separation,
    /// drive pair stiffness, back pair stiffness), so that one pair's lookup reads one cache
    /// line; empty with more than one slice.
    packed: Vec<[f64; 4]>,
    /// 1/step of the tables \[1/m\], p_b/step and its reciprocal, as the hot path computes them,
    /// and 1/p_b \[1/m\].
    inv_step: f64,
    inv_base_pitch: f64,
    per_pitch: f64,
    inv_per_pitch: f64,
}

/// State of one tooth pair at one instant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairContact {
    /// Pair index relative to the reference tooth (0), the next tooth of gear 1 is 1.
    pub index: i32,
    /// Drive-flank position on the line of action \[m\].
    pub position: f64,
    /// Force along the line of action \[N\]; negative on the back flank.
    pub force: f64,
    /// Stiffness of the pair in contact [N/m] (0 when open).
    pub stiffness: f64,
    /// Largest load per unit face width over the slices [N/m].
    pub max_line_load: f64,
}

/// The contact law of one tooth pair at one instant, summed over face slices.
#[derive(Clone, Copy, Debug, Default)]
struct PairLaw {
    force: f64,
    stiffness: f64,
    /// ∂k/∂s of the touching slices' stiffness along the table [N/m²].
    stiffness_slope: f64,
    position_derivative: f64,
    energy: f64,
    energy_derivative: f64,
    max_line_load: f64,
    event_drive: f64,
    event_back: f64,
}

/// The mesh force and its derivatives at one state of a mesh
/// ([`MeshModel::force_with_derivatives`], [`MeshModel::force_tangents`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshLaw {
    /// Mesh force, the sum of the tooth-pair forces \[N\].
    pub force: f64,
    /// ∂F/∂δ [N/m].
    pub approach_stiffness: f64,
    /// ∂F/∂s [N/m].
    pub position_derivative: f64,
    /// The largest tooth-pair force of the mesh in magnitude, on either
    /// flank \[N\] (0 when no pair touches).
    pub peak_pair_force: f64,
}

/// Samples per base pitch of the contact tables.
pub const TABLE_SAMPLES_PER_PITCH: usize = 400;

/// One slice's contact: the sign of the force, the penetration \[m\], the
/// pair stiffness table, the separation table of the flank in contact and
/// the slope of its edge relief [-].
type SliceContact<'a> = (f64, f64, &'a [f64], &'a [f64], f64);

impl MeshModel {
    /// The contact model of a mesh whose flanks carry the same deviations
    /// across the whole face.
    pub fn new(set: &GearSet, mesh: MeshKind, flanks: &MeshFlanks) -> Self {
        Self::sliced(set, mesh, std::slice::from_ref(flanks))
    }

    /// The contact model of a mesh cut into `slices.len()` slices across the
    /// face, slice j with flank deviations `slices[j]` (no slices means one
    /// unworn slice). Slices with equal deviations share one computation.
    pub fn sliced(set: &GearSet, mesh: MeshKind, slices: &[MeshFlanks]) -> Self {
        let path = PathOfContact::new(set, mesh);
        let step = path.base_pitch / TABLE_SAMPLES_PER_PITCH as f64;
        let default = [MeshFlanks::default()];
        let slices = if slices.is_empty() { &default[..] } else { slices };
        let mut tables: Vec<MeshSeparation> = Vec::with_capacity(slices.len());
        for (j, flanks) in slices.iter().enumerate() {
            match slices[..j].iter().position(|f| f == flanks) {
                Some(same) => tables.push(tables[same].clone()),
                None => tables.push(crate::contact::cache::separation(set, mesh, flanks, step)),
            }
        }
        let separation = tables[0].clone();
        let stiffness = PairStiffness::new(set, mesh);
        let drive_k: Vec<f64> = separation.drive.positions().map(|s| stiffness.at(s)).collect();
        let back_k: Vec<f64> =
            separation.back.positions().map(|s| stiffness.at(separation.back_mirror - s)).collect();
        let (g1, g2) = set.mesh_gears(mesh);
        let packed: Vec<[f64; 4]> = if tables.len() == 1 {
            (0..drive_k.len())
                .map(|i| [tables[0].drive.values[i], tables[0].back.values[i], drive_k[i], back_k[i]])
                .collect()
        } else {
            Vec::new()
        };
        let inv_step = 1.0 / separation.drive.step;
        let per_pitch = separation.path.base_pitch * inv_step;
        let inv_base_pitch = 1.0 / separation.path.base_pitch;
        Self {
            inv_base_pitch,
            inv_step,
            per_pitch,
            inv_per_pitch: 1.0 / per_pitch,
            separation,
            slices: tables,
            stiffness,
            face_width: g1.face_width.min(g2.face_width),
            drive_k,
            back_k,
            packed,
        }
    }

    /// The path of contact.
    pub fn path(&self) -> &PathOfContact {
        &self.separation.path
    }

    /// Range of pair indices k whose position s + k·p_b lies in the tables.
    fn pair_range(&self, s: f64) -> std::ops::RangeInclusive<i32> {
        let t = &self.separation.drive;
        let pb = self.path().base_pitch;
        let k_lo = (-floor_of_quotient(s - t.start, pb, self.inv_base_pitch)) as i32;
        let k_hi = floor_of_quotient(t.end() - s, pb, self.inv_base_pitch) as i32;
        k_lo..=k_hi
    }

    /// Which flank of one slice touches under approach `delta` \[m\], given the
    /// slice's drive and back separations `gd`, `gb` \[m\] at the pair's
    /// position, each with its edge relief and the relief's slope
    /// ([`MeshSeparation::drive_relief_at`]): the sign of the force, the
    /// penetration \[m\], the pair stiffness table, the slice's separation
    /// table of that flank and the slope of its edge relief [-].
    #[inline(always)]
    fn slice_contact<'a>(
        &'a self,
        slice: &'a MeshSeparation,
        (gd, (rd, drd)): (f64, (f64, f64)),
        (gb, (rb, drb)): (f64, (f64, f64)),
        delta: f64,
    ) -> Option<SliceContact<'a>> {
        if gd < NO_CONTACT && delta > gd + rd {
            return Some((1.0, delta - gd - rd, &self.drive_k, &slice.drive.values, drd));
        }
        if gb < NO_CONTACT && -delta > gb + rb {
            Some((-1.0, -delta - gb - rb, &self.back_k, &slice.back.values, drb))
        } else {
            None
        }
    }

    /// Force \[N\] of each face slice of the pair at position `pos` \[m\] under
    /// approach `delta` \[m\], written to `out` (one value per slice, negative
    /// on the back flank, zero outside the tables); they add up to
    /// [`Self::pair_force`]. The wear model reads the line load of each slice
    /// from here.
    pub fn pair_slice_forces(&self, pos: f64, delta: f64, out: &mut Vec<f64>) {
        out.clear();
        let grid = &self.separation.drive;
        if pos < grid.start || pos > grid.end() {
            out.resize(self.slices.len(), 0.0);
            return;
        }
        // The same cell and weights as the summed law of `pair`.
        let (i, t) = grid.cell(pos);
        let lerp = |v: &[f64]| v[i] + t * (v[i + 1] - v[i]);
        let fraction = 1.0 / self.slices.len() as f64;
        for slice in &self.slices {
            let (gd, gb) = (lerp(&slice.drive.values), lerp(&slice.back.values));
            let (rd, rb) = (slice.drive_relief_at(pos), slice.back_relief_at(pos));
            out.push(match self.slice_contact(slice, (gd, rd), (gb, rb), delta) {
                Some((sign, x, k_table, _, _)) => {
                    let k = fraction * lerp(k_table);
                    sign * k * x
                }
                None => 0.0,
            });
        }
    }

    /// Face width carried by the mesh, the narrower of its two gears \[m\].
    pub fn face_width(&self) -> f64 {
        self.face_width
    }

    /// Everything the contact law says about the pair at position `pos` \[m\]
    /// under approach `delta` \[m\], summed over the face slices: one table
    /// cell lookup serves every table (they share one grid).
    #[inline(always)]
    fn pair(&self, pos: f64, delta: f64) -> PairLaw {
        let grid = &self.separation.drive;
        let inv_step = 1.0 / grid.step;
        let (i, t) = grid.cell(pos);
        let lerp = |v: &[f64]| v[i] + t * (v[i + 1] - v[i]);
        let slope = |v: &[f64]| (v[i + 1] - v[i]) * inv_step;
        let fraction = 1.0 / self.slices.len() as f64;
        let inv_slice_width = 1.0 / (self.face_width * fraction);
        let mut law =
            PairLaw { event_drive: f64::NEG_INFINITY, event_back: f64::NEG_INFINITY, ..PairLaw::default() };
        for slice in &self.slices {
            let gd = lerp(&slice.drive.values);
            let gb = lerp(&slice.back.values);
            // A relieved edge adds its relief to the separation beyond the
            // involute path, so the event values stay continuous.
            let (rd, rb) = (slice.drive_relief_at(pos), slice.back_relief_at(pos));
            law.event_drive = law.event_drive.max(delta - gd - rd.0);
            law.event_back = law.event_back.max(-delta - gb - rb.0);
            let Some((sign, x, k_table, g_table, dr)) = self.slice_contact(slice, (gd, rd), (gb, rb), delta)
            else {
                continue;
            };
            let k = fraction * lerp(k_table);
            let dk = fraction * slope(k_table);
            let dg = slope(g_table) + dr;
            law.force += sign * k * x;
            law.stiffness += k;
            law.stiffness_slope += dk;
            law.position_derivative += sign * (dk * x - k * dg);
            law.energy += 0.5 * k * x * x;
            law.energy_derivative += 0.5 * dk * x * x - k * x * dg;
            law.max_line_load = law.max_line_load.max(k * x * inv_slice_width);
        }
        law
    }

    /// Force \[N\] of the single tooth pair at position `pos` \[m\] under
    /// approach `delta` \[m\] (zero outside the tables).
    pub fn pair_force(&self, pos: f64, delta: f64) -> f64 {
        let t = &self.separation.drive;
        if pos < t.start || pos > t.end() {
            return 0.0;
        }
        self.pair(pos, delta).force
    }

    /// Mesh force \[N\] and tangent stiffness [N/m] at approach `delta` \[m\],
    /// with the reference pair at position `s` \[m\]; pairs are filled into
    /// `pairs` when given.
    pub fn force(&self, s: f64, delta: f64, mut pairs: Option<&mut Vec<PairContact>>) -> (f64, f64) {
        if let Some(p) = pairs.as_deref_mut() {
            p.clear();
        }
        let pb = self.path().base_pitch;
        let (mut f, mut k) = (0.0, 0.0);
        for index in self.pair_range(s) {
            let pos = s + f64::from(index) * pb;
            let law = self.pair(pos, delta);
            f += law.force;
            k += law.stiffness;
            if let Some(p) = pairs.as_deref_mut() {
                p.push(PairContact {
                    index,
                    position: pos,
                    force: law.force,
                    stiffness: law.stiffness,
                    max_line_load: law.max_line_load,
                });
            }
        }
        (f, k)
    }

    /// Mesh force \[N\], its derivatives ∂F/∂δ [N/m] and ∂F/∂s [N/m] (the
    /// exact derivatives of the interpolated contact law, contact status
    /// frozen), and the event values of the pairs: for pair k the value
    /// δ − g_drive (drive flank) and −δ − g_back (back flank) are written to
    /// slot `2·(k mod slots)` and `2·(k mod slots) + 1` of `events`, which
    /// must hold `2·slots` values; slots of pairs outside the tables read
    /// −[`NO_CONTACT`]. Each slot's value is continuous in s because pairs
    /// enter and leave the tables out of contact.
    pub fn force_with_derivatives(&self, s: f64, delta: f64, events: &mut [f64]) -> MeshLaw {
        if self.packed.len() < 2 {
            return self.force_with_derivatives_sliced(s, delta, events);
        }
        let pb = self.path().base_pitch;
        let slots = events.len() / 2;
        for e in events.iter_mut() {
            *e = -NO_CONTACT;
        }
        // The arithmetic of `pair` with one slice (its share of the stiffness, 1/1, is exact),
        // reading the interleaved tables: the same cell and weights, the same sums in the same
        // order, without the energy terms.
        let g = &self.packed;
        let slice = &self.slices[0];
        let grid = &self.separation.drive;
        let inv_step = 1.0 / grid.step;
        let last = g.len() - 1;
        let range = self.pair_range(s);
        let mut slot =
            if slots > 0 { 2 * (i64::from(*range.start()).rem_euclid(slots as i64) as usize) } else { 0 };
        let mut out = MeshLaw::default();
        for index in range {
            let pos = s + f64::from(index) * pb;
            let x = ((pos - grid.start) * inv_step).clamp(0.0, last as f64);
            // x is in [0, last] or NaN: through i64 the same index as `x as usize` (NaN gives 0),
            // and back the same float, without the unsigned conversions baseline x86-64 lacks.
            let i = (x as i64 as usize).min(last - 1);
            let t = x - i as i64 as f64;
            let (a, b) = (g[i], g[i + 1]);
            let gd = a[0] + t * (b[0] - a[0]);
            let gb = a[1] + t * (b[1] - a[1]);
            let (rd, drd) = slice.drive_relief_at(pos);
            let (rb, drb) = slice.back_relief_at(pos);
            let (force, stiffness, position_derivative) = if gd < NO_CONTACT && delta > gd + rd {
                let pen = delta - gd - rd;
                let k = a[2] + t * (b[2] - a[2]);
                let dk = (b[2] - a[2]) * inv_step;
                let dg = (b[0] - a[0]) * inv_step + drd;
                (0.0 + k * pen, 0.0 + k, 0.0 + (dk * pen - k * dg))
            } else if gb < NO_CONTACT && -delta > gb + rb {
                let pen = -delta - gb - rb;
                let k = a[3] + t * (b[3] - a[3]);
                let dk = (b[3] - a[3]) * inv_step;
                let dg = (b[1] - a[1]) * inv_step + drb;
                (0.0 + -(k * pen), 0.0 + k, 0.0 + -(dk * pen - k * dg))
            } else {
                (0.0, 0.0, 0.0)
            };
            out.force += force;
            out.approach_stiffness += stiffness;
            out.position_derivative += position_derivative;
            out.peak_pair_force = out.peak_pair_force.max(force.abs());
            if slots > 0 {
                events[slot] = f64::NEG_INFINITY.max(delta - gd - rd);
                events[slot + 1] = f64::NEG_INFINITY.max(-delta - gb - rb);
                slot += 2;
                if slot == 2 * slots {
                    slot = 0;
                }
            }
        }
        out
    }

    /// [`Self::force_with_derivatives`] summed slice by slice over the face, whatever the
    /// number of slices: the general path, and the reference its single-slice path (read from
    /// the interleaved tables) is tested against; the same values.
    pub fn force_with_derivatives_sliced(&self, s: f64, delta: f64, events: &mut [f64]) -> MeshLaw {
        let pb = self.path().base_pitch;
        let slots = events.len() / 2;
        for e in events.iter_mut() {
            *e = -NO_CONTACT;
        }
        let mut out = MeshLaw::default();
        for index in self.pair_range(s) {
            let law = self.pair(s + f64::from(index) * pb, delta);
            out.force += law.force;
            out.approach_stiffness += law.stiffness;
            out.position_derivative += law.position_derivative;
            out.peak_pair_force = out.peak_pair_force.max(law.force.abs());
            // No slots (the hot path of a face cut in slices) asks for no
            // event values.
            if slots > 0 {
                let slot = 2 * (i64::from(index).rem_euclid(slots as i64) as usize);
                events[slot] = law.event_drive;
                events[slot + 1] = law.event_back;
            }
        }
        out
    }

    /// Mesh force \[N\] and its derivatives ∂F/∂δ [N/m] and ∂F/∂s [N/m], as
    /// [`Self::force_with_derivatives`] without the event values: the
    /// dynamic model's hot path, with a single face slice read from the
    /// interleaved tables.
    pub fn force_tangents(&self, s: f64, delta: f64) -> MeshLaw {
        let g = &self.packed;
        if g.len() < 2 {
            return self.force_with_derivatives_sliced(s, delta, &mut []);
        }
        let grid = &self.separation.drive;
        let (inv_step, per_pitch) = (self.inv_step, self.per_pitch);
        let last = (g.len() - 1) as i64 as f64;
        // Pair k sits at grid coordinate x0 + k·(p_b/step); the pairs in the tables are those
        // with 0 ≤ x ≤ last.
        let x0 = (s - grid.start) * inv_step;
        let k_lo = -floor_of_quotient(x0, per_pitch, self.inv_per_pitch);
        let k_hi = floor_of_quotient(last - x0, per_pitch, self.inv_per_pitch);
        // Counted, not stepped by k += 1: at a travel beyond 2^53 pitches
        // (a diverging iterate) k + 1 == k and a stepped loop never ends.
        let pairs = if k_hi >= k_lo { ((k_hi - k_lo) as usize + 1).min(last as usize + 2) } else { 0 };
        let sep = &self.separation;
        let pb = self.path().base_pitch;
        let mut out = MeshLaw::default();
        for j in 0..pairs {
            // Signed conversions (the same values here) instead of the unsigned ones, which
            // baseline x86-64 has no instruction for.
            let k = k_lo + j as i64 as f64;
            let x = (x0 + k * per_pitch).clamp(0.0, last);
            let i = (x as i64 as usize).min(g.len() - 2);
            let t = x - i as i64 as f64;
            let (a, b) = (g[i], g[i + 1]);
            let gd = a[0] + t * (b[0] - a[0]);
            let pos = s + k * pb;
            let (rd, drd) = sep.drive_relief_at(pos);
            let (sign, pen, kk, dk, dg) = if gd < NO_CONTACT && delta > gd + rd {
                (
                    1.0,
                    delta - gd - rd,
                    a[2] + t * (b[2] - a[2]),
                    (b[2] - a[2]) * inv_step,
                    (b[0] - a[0]) * inv_step + drd,
                )
            } else {
                let gb = a[1] + t * (b[1] - a[1]);
                let (rb, drb) = sep.back_relief_at(pos);
                if gb < NO_CONTACT && -delta > gb + rb {
                    (
                        -1.0,
                        -delta - gb - rb,
                        a[3] + t * (b[3] - a[3]),
                        (b[3] - a[3]) * inv_step,
                        (b[1] - a[1]) * inv_step + drb,
                    )
                } else {
                    continue;
                }
            };
            let pair = kk * pen;
            out.force += sign * pair;
            out.approach_stiffness += kk;
            out.position_derivative += sign * (dk * pen - kk * dg);
            out.peak_pair_force = out.peak_pair_force.max(pair);
        }
        out
    }

    /// The derivatives of the tangent stiffness K_t = ∂F/∂δ at (s, δ), contact
    /// status frozen: (∂K_t/∂δ, ∂K_t/∂s) [N/m², N/m²]. A pair's force is
    /// linear in its penetration, so ∂K_t/∂δ = 0, and ∂K_t/∂s is the sum of
    /// the touching pairs' stiffness slopes along their tables: the exact
    /// derivatives of the interpolated law, which Rayleigh damping's tangent
    /// reads.
    pub fn stiffness_derivatives(&self, s: f64, delta: f64) -> (f64, f64) {
        let pb = self.path().base_pitch;
        let slope =
            self.pair_range(s).map(|index| self.pair(s + f64::from(index) * pb, delta).stiffness_slope).sum();
        (0.0, slope)
    }

    /// Elastic energy stored in the mesh's pairs, V = Σ ½k(s_k)(δ − g(s_k))²
    /// \[J\], and its partial derivative ∂V/∂s at fixed δ \[N\]: the power
    /// ∂V/∂s · ṡ is the work rate of the time-varying stiffness and
    /// separation that an energy balance must account for.
    pub fn contact_energy(&self, s: f64, delta: f64) -> (f64, f64) {
        let pb = self.path().base_pitch;
        self.pair_range(s)
            .map(|index| self.pair(s + f64::from(index) * pb, delta))
            .fold((0.0, 0.0), |(v, dv), law| (v + law.energy, dv + law.energy_derivative))
    }

    /// Event slots a mesh needs: more than the pairs its tables can hold.
    pub fn event_slots(&self) -> usize {
        let t = &self.separation.drive;
        ((t.end() - t.start) / self.path().base_pitch).ceil() as usize + 2
    }

    /// Sum of the pair stiffnesses of the pairs on the nominal (sharp-tip)
    /// path at position `s` [N/m]: the geometric mesh stiffness.
    pub fn nominal_mesh_stiffness(&self, s: f64) -> f64 {
        let p = self.path();
        self.pair_range(s)
            .map(|i| s + f64::from(i) * p.base_pitch)
            .filter(|pos| *pos >= p.start_sharp && *pos <= p.end_sharp)
            .map(|pos| self.stiffness.at(pos))
            .sum()
    }

    /// Approach \[m\] at which the mesh carries `load` \[N\] with the reference
    /// pair at `s`.
    pub fn approach_for(&self, s: f64, load: f64) -> f64 {
        solve_increasing(|d| self.force(s, d, None), load, 0.0)
    }

    /// First and last position \[m\] at which one tooth pair carries load
    /// while the mesh transmits `load` \[N\] along its line of action: the
    /// loaded engagement, corner contact included. Found by a scan over the
    /// path ± one base pitch and bisection to 1e-12 of a base pitch, so it
    /// varies smoothly with the geometry (the share of a sampled cycle moves
    /// in steps of one sample).
    pub fn loaded_engagement(&self, load: f64) -> (f64, f64) {
        let p = self.path();
        let pb = p.base_pitch;
        let loaded = |s: f64| self.pair_force(s, self.approach_for(s, load)) > 0.0;
        let (lo, hi) = (p.start.min(p.start_sharp) - pb, p.end.max(p.end_sharp) + pb);
        loaded_span(lo, hi, 400, loaded, Refine::Width(1e-12 * pb)).unwrap_or((p.start, p.end))
    }

    /// Loaded contact ratio at `load` \[N\]: the loaded engagement over the
    /// base pitch [-].
    pub fn loaded_contact_ratio(&self, load: f64) -> f64 {
        let (a, b) = self.loaded_engagement(load);
        (b - a) / self.path().base_pitch
    }

    /// Share of the mesh cycle with two or more pairs loaded at `load` \[N\]:
    /// ε − 1 for a loaded contact ratio ε between 1 and 2 [-].
    pub fn double_contact_share(&self, load: f64) -> f64 {
        (self.loaded_contact_ratio(load) - 1.0).clamp(0.0, 1.0)
    }
}

/// How [`loaded_span`] refines an end found by its scan.
#[derive(Clone, Copy, Debug)]
pub enum Refine {
    /// Bisect until the bracket is at most this wide \[m\].
    Width(f64),
    /// Bisect this many times.
    Steps(usize),
}

/// First and last position in [`lo`, `hi`] where `loaded` holds: a scan of
/// `n` equal intervals, then bisection of each end's bracket as `refine`
/// says. An end that lies on the scan's edge is that edge; `None` when no
/// scanned position is loaded.
pub fn loaded_span(
    lo: f64,
    hi: f64,
    n: usize,
    mut loaded: impl FnMut(f64) -> bool,
    refine: Refine,
) -> Option<(f64, f64)> {
    let at = |i: usize| lo + (hi - lo) * i as f64 / n as f64;
    let flags: Vec<bool> = (0..=n).map(|i| loaded(at(i))).collect();
    let first = flags.iter().position(|f| *f)?;
    let last = flags.iter().rposition(|f| *f)?;
    let mut bisect = |mut out: f64, mut inside: f64| {
        let mut steps = 0;
        while match refine {
            Refine::Width(w) => (out - inside).abs() > w,
            Refine::Steps(k) => steps < k,
        } {
            let mid = 0.5 * (out + inside);
            if loaded(mid) {
                inside = mid;
            } else {
                out = mid;
            }
            steps += 1;
        }
        inside
    };
    let start = if first == 0 { at(0) } else { bisect(at(first - 1), at(first)) };
    let end = if last == n { at(n) } else { bisect(at(last + 1), at(last)) };
    Some((start, end))
}

/// Solves f(x) = target for a non-decreasing piecewise-linear f given with
/// its slope, by Newton steps safeguarded with bisection once bracketed.
fn solve_increasing(f: impl Fn(f64) -> (f64, f64), target: f64, x0: f64) -> f64 {
    match try_solve_increasing(|x| Ok::<_, std::convert::Infallible>(f(x)), target, x0, 200) {
        Ok(x) | Err((_, x)) => x,
    }
}

/// [`solve_increasing`] for an f that may fail: Newton steps from `x0`
/// safeguarded with bisection once bracketed, to 1e-13 of x (the bracket) or
/// 1e-14 (the step). An error of f is passed on as `Err((Some(e), x))`; no
/// convergence within `iterations` steps gives `Err((None, x))` with the
/// last iterate.
pub(crate) fn try_solve_increasing<E>(
    f: impl Fn(f64) -> Result<(f64, f64), E>,
    target: f64,
    x0: f64,
    iterations: usize,
) -> Result<f64, (Option<E>, f64)> {
    let scale = 1e-5;
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut x = x0;
    for _ in 0..iterations {
        let (v, slope) = f(x).map_err(|e| (Some(e), x))?;
        let r = v - target;
        if r == 0.0 {
            return Ok(x);
        }
        if r < 0.0 {
            lo = lo.max(x);
        } else {
            hi = hi.min(x);
        }
        let mut next = if slope > 0.0 {
            x - r / slope
        } else if r < 0.0 {
            x + scale
        } else {
            x - scale
        };
        if lo.is_finite() && hi.is_finite() {
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if hi - lo <= 1e-16 + 1e-13 * x.abs() {
                return Ok(0.5 * (lo + hi));
            }
        } else if lo.is_finite() && next <= lo {
            next = lo + scale;
        } else if hi.is_finite() && next >= hi {
            next = hi - scale;
        }
        if (next - x).abs() <= 1e-18 + 1e-14 * x.abs() {
            return Ok(next);
        }
        x = next;
    }
    Err((None, x))
}

/// Summary of a periodic quantity over a mesh cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CycleStats {
    /// Mean.
    pub mean: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
    /// Maximum − minimum.
    pub peak_to_peak: f64,
}

impl CycleStats {
    /// Statistics of samples evenly spread over one cycle.
    pub fn of(v: &[f64]) -> Self {
        let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
        let min = v.iter().cloned().fold(f64::INFINITY, f64::min);
        let max = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        Self { mean, min, max, peak_to_peak: max - min }
    }
}

/// LTCA of one mesh over one mesh cycle at a constant transmitted load.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshLtca {
    /// Mesh name.
    pub name: String,
    /// Load along the line of action \[N\].
    pub load: f64,
    /// Reference-pair positions over one cycle \[m\].
    pub position: Vec<f64>,
    /// Roll angle of gear 1 at the reference position \[rad\].
    pub roll_angle_gear1: Vec<f64>,
    /// Loaded static transmission error: the approach along the line of action \[m\].
    pub transmission_error: Vec<f64>,
    /// Tangent mesh stiffness of the loaded mesh [N/m].
    pub mesh_stiffness_loaded: Vec<f64>,
    /// Sum of pair stiffnesses on the nominal path [N/m].
    pub mesh_stiffness_nominal: Vec<f64>,
    /// Pairs carrying load at each position.
    pub pairs_in_contact: Vec<u32>,
    /// Largest Hertzian peak pressure of any pair \[Pa\].
    pub peak_pressure: Vec<f64>,
    /// Largest Hertzian half-width of any pair \[m\].
    pub half_width: Vec<f64>,
    /// One tooth pair's load through its whole engagement: positions \[m\].
    pub pair_path_position: Vec<f64>,
    /// ... its gear-1 roll angles \[rad\].
    pub pair_path_roll_gear1: Vec<f64>,
    /// ... its load \[N\].
    pub pair_path_load: Vec<f64>,
    /// ... its Hertzian peak pressure \[Pa\].
    pub pair_path_peak_pressure: Vec<f64>,
    /// ... its Hertzian half-width \[m\].
    pub pair_path_half_width: Vec<f64>,
}

impl MeshLtca {
    /// Loaded contact ratio: the mean number of loaded pairs.
    pub fn loaded_contact_ratio(&self) -> f64 {
        self.pairs_in_contact.iter().map(|n| f64::from(*n)).sum::<f64>() / self.pairs_in_contact.len() as f64
    }

    /// Fraction of the cycle with exactly `n` pairs in contact.
    pub fn fraction_with_pairs(&self, n: u32) -> f64 {
        self.pairs_in_contact.iter().filter(|k| **k == n).count() as f64 / self.pairs_in_contact.len() as f64
    }
}

fn hertz_of(model: &MeshModel, set: &GearSet, pos: f64, line_load: f64) -> (f64, f64) {
    let p = model.path();
    let s = pos.clamp(p.start, p.end);
    let e_star = contact_modulus(
        set.material().youngs_modulus,
        set.material().poisson_ratio,
        set.material().youngs_modulus,
        set.material().poisson_ratio,
    );
    let c = line_contact(line_load, p.rho_1(s), p.rho_2(s), p.kind == GearKind::Internal, e_star);
    (c.peak_pressure, c.half_width)
}

/// LTCA of one mesh carrying `load` \[N\] along its line of action, at
/// `samples` positions over one mesh cycle.
pub fn mesh_ltca(set: &GearSet, model: &MeshModel, load: f64, samples: usize) -> MeshLtca {
    let p = model.path().clone();
    let mut out = MeshLtca {
        name: p.mesh.name().into(),
        load,
        position: Vec::new(),
        roll_angle_gear1: Vec::new(),
        transmission_error: Vec::new(),
        mesh_stiffness_loaded: Vec::new(),
        mesh_stiffness_nominal: Vec::new(),
        pairs_in_contact: Vec::new(),
        peak_pressure: Vec::new(),
        half_width: Vec::new(),
        pair_path_position: Vec::new(),
        pair_path_roll_gear1: Vec::new(),
        pair_path_load: Vec::new(),
        pair_path_peak_pressure: Vec::new(),
        pair_path_half_width: Vec::new(),
    };
    let mut pairs = Vec::new();
    let mut along: Vec<(f64, f64, f64, f64)> = Vec::new();
    let mut delta = 0.0;
    for i in 0..samples {
        let s = p.start + p.base_pitch * i as f64 / samples as f64;
        delta = solve_increasing(|d| model.force(s, d, None), load, delta);
        let (_, k) = model.force(s, delta, Some(&mut pairs));
        let mut n = 0;
        let (mut pmax, mut bmax): (f64, f64) = (0.0, 0.0);
        for c in &pairs {
            let (pp, b) = hertz_of(model, set, c.position, c.max_line_load);
            if c.force != 0.0 {
                n += 1;
                pmax = pmax.max(pp);
                bmax = bmax.max(b);
            }
            along.push((c.position, c.force, pp, b));
        }
        out.position.push(s);
        out.roll_angle_gear1.push(p.roll_1(s));
        out.transmission_error.push(delta);
        out.mesh_stiffness_loaded.push(k);
        out.mesh_stiffness_nominal.push(model.nominal_mesh_stiffness(s));
        out.pairs_in_contact.push(n);
        out.peak_pressure.push(pmax);
        out.half_width.push(bmax);
    }
    along.sort_by(|a, b| a.0.total_cmp(&b.0));
    let first = along.iter().position(|a| a.1 != 0.0).unwrap_or(0).saturating_sub(1);
    let last = (along.iter().rposition(|a| a.1 != 0.0).unwrap_or(0) + 2).min(along.len());
    for (pos, f, pp, b) in &along[first..last] {
        out.pair_path_position.push(*pos);
        out.pair_path_roll_gear1.push(p.roll_1(*pos));
        out.pair_path_load.push(*f);
        out.pair_path_peak_pressure.push(*pp);
        out.pair_path_half_width.push(*b);
    }
    out
}

/// A mesh's force \[N\] and tangent stiffness [N/m] at reference position s
/// and approach δ: what the set's equilibrium reads of a mesh law.
pub trait MeshForce {
    /// (F, ∂F/∂δ) at (s, δ).
    fn force_stiffness(&self, s: f64, delta: f64) -> (f64, f64);
}

impl MeshForce for MeshModel {
    fn force_stiffness(&self, s: f64, delta: f64) -> (f64, f64) {
        self.force(s, delta, None)
    }
}

/// Contact models of both meshes of a set with its planet phasing.
#[derive(Clone, Debug)]
pub struct SetModel {
    /// Sun–planet mesh model.
    pub sun_planet: MeshModel,
    /// Ring–planet mesh model.
    pub ring_planet: MeshModel,
    /// Planet angles \[rad\].
    pub planet_angles: Vec<f64>,
    base_radius_sun: f64,
    /// Offset \[m\] from a planet's sun-mesh position to its ring-mesh position.
    pub ring_shift: f64,
    /// The flank deviations per face slice the models were built with
    /// (sun–planet, ring–planet; unworn slices when built without).
    flanks: [Vec<MeshFlanks>; 2],
}

impl SetModel {
    /// Models of both meshes, unworn, with the scene's face slices.
    pub fn new(set: &GearSet) -> Self {
        let slices = vec![MeshFlanks::default(); set.analysis().face_slices.max(1)];
        Self::with_flanks(set, &slices, &slices)
    }

    /// Models of both meshes with flank deviations per face slice.
    pub fn with_flanks(set: &GearSet, sun_planet: &[MeshFlanks], ring_planet: &[MeshFlanks]) -> Self {
        let sp = MeshModel::sliced(set, MeshKind::SunPlanet, sun_planet);
        let rp = MeshModel::sliced(set, MeshKind::RingPlanet, ring_planet);
        // Planet tooth directions seen from the sun mesh (a space facing the
        // sun) and from the mirrored ring mesh (a tooth facing the ring)
        // differ by π + π/Z_p; both meshes' positions follow the planet's
        // angle, so the ring position is the sun position shifted by
        // (offset_r − offset_s) − j_n,s/2 − r_b,p (π + π/Z_p).
        let off = |m: &MeshModel| m.separation.back_mirror / 2.0 - m.separation.normal_backlash / 2.0;
        let zp = f64::from(set.planet().teeth);
        let ring_shift = off(&rp)
            - off(&sp)
            - sp.separation.normal_backlash / 2.0
            - set.planet().base_radius() * (std::f64::consts::PI + std::f64::consts::PI / zp);
        Self {
            sun_planet: sp,
            ring_planet: rp,
            planet_angles: set.planet_angles().to_vec(),
            base_radius_sun: set.sun().base_radius(),
            ring_shift,
            flanks: [sun_planet, ring_planet].map(|f| {
                if f.is_empty() {
                    vec![MeshFlanks::default()]
                } else {
                    f.to_vec()
                }
            }),
        }
    }

    /// The flank deviations per face slice of mesh `kind`.
    pub fn flanks(&self, kind: MeshKind) -> &[MeshFlanks] {
        match kind {
            MeshKind::SunPlanet => &self.flanks[0],
            MeshKind::RingPlanet => &self.flanks[1],
        }
    }

    /// Sun-mesh reference position of planet `n` at sun travel `lambda` \[m\].
    pub fn sun_position(&self, n: usize, lambda: f64) -> f64 {
        let p = self.sun_planet.path();
        let s = lambda - self.base_radius_sun * self.planet_angles[n];
        p.start + (s - p.start).rem_euclid(p.base_pitch)
    }

    /// Ring-mesh reference position of planet `n` at sun travel `lambda` \[m\].
    pub fn ring_position(&self, n: usize, lambda: f64) -> f64 {
        let p = self.ring_planet.path();
        let s = self.sun_position(n, lambda) + self.ring_shift;
        p.start + (s - p.start).rem_euclid(p.base_pitch)
    }

    /// Static equilibrium of the whole set at sun travel `lambda` \[m\] under
    /// the total tooth force `total` \[N\] (n·F, shared by the planets),
    /// starting the iterations from `guess` (a neighbouring equilibrium or
    /// [`SetEquilibrium::unloaded`]).
    pub fn equilibrium(&self, total: f64, lambda: f64, guess: &SetEquilibrium) -> SetEquilibrium {
        self.equilibrium_on(&self.sun_planet, &self.ring_planet, total, lambda, guess)
    }

    /// [`Self::equilibrium`] with the mesh laws `sp` (sun–planet) and `rp`
    /// (ring–planet) in place of the pair models (the deformable law: the
    /// same paths of contact and phasing).
    pub fn equilibrium_on(
        &self,
        sp: &dyn MeshForce,
        rp: &dyn MeshForce,
        total: f64,
        lambda: f64,
        guess: &SetEquilibrium,
    ) -> SetEquilibrium {
        let n = self.planet_angles.len();
        let guesses: Vec<f64> =
            (0..n).map(|p| guess.sun_mesh_approach.get(p).copied().unwrap_or(0.0)).collect();
        let g = |u: f64| {
            let mut f = 0.0;
            let mut k = 0.0;
            for (p, guess) in guesses.iter().enumerate() {
                let (fp, x) = self.planet_load_on(sp, rp, p, lambda, u, *guess);
                f += fp;
                // Series stiffness of the planet's two meshes at this state.
                let ks = sp.force_stiffness(self.sun_position(p, lambda), x).1;
                let kr = rp.force_stiffness(self.ring_position(p, lambda), u - x).1;
                if ks + kr > 0.0 {
                    k += ks * kr / (ks + kr);
                }
            }
            (f, k)
        };
        let us = solve_increasing(g, total, guess.sun_approach);
        let mut out = SetEquilibrium {
            sun_approach: us,
            sun_mesh_approach: Vec::with_capacity(n),
            planet_load: Vec::with_capacity(n),
        };
        for (p, guess) in guesses.iter().enumerate() {
            let (f, x) = self.planet_load_on(sp, rp, p, lambda, us, *guess);
            out.sun_mesh_approach.push(x);
            out.planet_load.push(f);
        }
        out
    }

    /// Load \[N\] through planet `n` when the sun has advanced `u_s` \[m\]
    /// elastically, with the approach of its sun mesh.
    pub fn planet_load(&self, n: usize, lambda: f64, u_s: f64, guess: f64) -> (f64, f64) {
        self.planet_load_on(&self.sun_planet, &self.ring_planet, n, lambda, u_s, guess)
    }

    /// [`Self::planet_load`] on the mesh laws `sp` and `rp`.
    fn planet_load_on(
        &self,
        sp: &dyn MeshForce,
        rp: &dyn MeshForce,
        n: usize,
        lambda: f64,
        u_s: f64,
        guess: f64,
    ) -> (f64, f64) {
        let ss = self.sun_position(n, lambda);
        let sr = self.ring_position(n, lambda);
        let g = |x: f64| {
            let (fs, ks) = sp.force_stiffness(ss, x);
            let (fr, kr) = rp.force_stiffness(sr, u_s - x);
            (fs - fr, ks + kr)
        };
        let x = solve_increasing(g, 0.0, guess);
        (sp.force_stiffness(ss, x).0, x)
    }
}

/// Static equilibrium of the whole set at one sun travel.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SetEquilibrium {
    /// Sun rotation as displacement along the line of action \[m\].
    pub sun_approach: f64,
    /// Approach of each planet's sun mesh \[m\]; its ring mesh's approach is
    /// `sun_approach` minus this.
    pub sun_mesh_approach: Vec<f64>,
    /// Load through each planet \[N\].
    pub planet_load: Vec<f64>,
}

impl SetEquilibrium {
    /// The unloaded set of `planets` planets: the starting guess of a first solve.
    pub fn unloaded(planets: usize) -> Self {
        Self { sun_approach: 0.0, sun_mesh_approach: vec![0.0; planets], planet_load: vec![0.0; planets] }
    }
}

/// Whole-set LTCA result over one mesh cycle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetLtca {
    /// Sun travel along the line of action \[m\].
    pub travel: Vec<f64>,
    /// Sun rotation as displacement along the line of action \[m\] (the set's
    /// static transmission error at the sun).
    pub sun_approach: Vec<f64>,
    /// Load of each planet at each position \[N\]: `planet_load[n][i]`.
    pub planet_load: Vec<Vec<f64>>,
    /// Mean load of each planet over the cycle \[N\].
    pub planet_mean_load: Vec<f64>,
    /// Largest instantaneous planet load over the mean planet load.
    pub load_sharing_factor: f64,
}

/// Quasi-static LTCA of the whole set under the input torque: the total
/// tooth force n·F of [`GearSet::mesh_load_per_planet`] on the drive flanks,
/// whichever member is driven (the carrier-frame torque balance gives the
/// same tooth forces for every choice of held and driven member).
pub fn set_ltca(set: &GearSet, model: &SetModel, samples: usize) -> SetLtca {
    let n = model.planet_angles.len();
    let total = set.mesh_load_per_planet() * n as f64;
    let pb = model.sun_planet.path().base_pitch;
    let mut state = SetEquilibrium::unloaded(n);
    let mut out = SetLtca {
        travel: Vec::new(),
        sun_approach: Vec::new(),
        planet_load: vec![Vec::new(); n],
        planet_mean_load: vec![0.0; n],
        load_sharing_factor: 0.0,
    };
    for i in 0..samples {
        let lambda = pb * i as f64 / samples as f64;
        state = model.equilibrium(total, lambda, &state);
        out.travel.push(lambda);
        out.sun_approach.push(state.sun_approach);
        for (p, f) in state.planet_load.iter().enumerate() {
            out.planet_load[p].push(*f);
        }
    }
    let mean_all = total / n as f64;
    for p in 0..n {
        out.planet_mean_load[p] = out.planet_load[p].iter().sum::<f64>() / samples as f64;
    }
    out.load_sharing_factor = out.planet_load.iter().flatten().cloned().fold(0.0, f64::max) / mean_all;
    out
}

/// `(a / b).floor()` for b > 0 \[-\], given `inv_b` = 1/b: mostly without the division.
/// The product a·(1/b) is within 4e-10 of the quotient a/b while |a·(1/b)| < 1e6 (two
/// roundings of at most 2⁻⁵³ each on the product, one on the quotient), so when it lies farther
/// than 1e-9 from every integer both have the same floor; otherwise (and for NaN and the
/// infinities) the quotient is taken.
#[inline(always)]
fn floor_of_quotient(a: f64, b: f64, inv_b: f64) -> f64 {
    let estimate = a * inv_b;
    if estimate.abs() < 1.0e6 {
        let floor = fast_floor(estimate);
        let fraction = estimate - floor;
        if fraction > 1.0e-9 && fraction < 1.0 - 1.0e-9 {
            return floor;
        }
    }
    fast_floor(a / b)
}

/// `x.floor()` without the library call (the release build targets baseline
/// x86-64, which has no rounding instruction): the same value for every
/// finite x, NaN and the infinities through `floor` itself. On the dynamic
/// model's hot path ([`MeshModel::force_tangents`]).
#[inline(always)]
fn fast_floor(x: f64) -> f64 {
    if x.abs() < 4.0e15 {
        let t = x as i64 as f64;
        if t > x {
            t - 1.0
        } else {
            t
        }
    } else {
        x.floor()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The floor of a quotient without the division is the floor of the quotient, on the
    /// example's pitch ratios, at and next to every integer, and for NaN and the infinities.
    #[test]
    fn floor_of_quotient_is_the_floor_of_the_quotient() {
        let check = |a: f64, b: f64| {
            let got = floor_of_quotient(a, b, 1.0 / b);
            let want = (a / b).floor();
            assert!(got == want || (got.is_nan() && want.is_nan()), "{a} / {b}: {got} vs {want}");
        };
        for b in [400.0, 0.0123456789, 1.0 / 3.0, 7.5e-3, 1e-300, 3.0e5] {
            for n in -2000..2000 {
                let a = f64::from(n) * b;
                let mut below = a;
                let mut above = a;
                for _ in 0..8 {
                    check(below, b);
                    check(above, b);
                    below = below.next_down();
                    above = above.next_up();
                }
                check(a + 0.37 * b, b);
            }
            for a in [0.0, -0.0, 1e6 * b, -1e6 * b, 1e300, -1e300, f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
            {
                check(a, b);
            }
        }
    }
}
