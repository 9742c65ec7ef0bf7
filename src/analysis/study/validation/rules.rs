//! The rules that the forced-response rows apply to the sweeps' curves:
//! which speeds form the jump's two-branch band, where the down sweep leaves
//! the upper branch, whether separation grows along it, which peaks lie near
//! a named speed, and how long a stretch of speeds a condition holds on.
//! They read curves only, so that each rule is tested on synthetic curves.

use super::{Curve, CurvePoint};
use crate::scene::units::rad_per_s_to_rpm;

/// A speed of the f₂ ≈ 2 f_m window where the up and down sweeps differ by
/// more than the band's share of F^(rms).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BandPoint {
    /// Index of the speed on the sweep grid.
    pub index: usize,
    /// Input speed \[rpm\].
    pub rpm: f64,
    /// F^(rms) of the sun–planet mesh on the up sweep \[N\].
    pub up: f64,
    /// F^(rms) of the sun–planet mesh on the down sweep \[N\].
    pub down: f64,
    /// The larger separation share of the sun–planet mesh of the two directions [-].
    pub separation: f64,
}

impl BandPoint {
    /// How far the two directions differ, as a share of the larger F^(rms) [-].
    pub fn difference(&self) -> f64 {
        (self.up - self.down).abs() / self.up.max(self.down)
    }
}

/// Splits `band` (in grid order) into the contiguous stretch of grid
/// indices that holds the largest difference between the directions, and
/// the points outside that stretch (the strays).
pub(super) fn contiguous_band(band: &[BandPoint]) -> (Vec<BandPoint>, Vec<BandPoint>) {
    let Some(top) = (0..band.len()).max_by(|&a, &b| band[a].difference().total_cmp(&band[b].difference()))
    else {
        return (Vec::new(), Vec::new());
    };
    let mut first = top;
    while first > 0 && band[first - 1].index + 1 == band[first].index {
        first -= 1;
    }
    let mut last = top;
    while last + 1 < band.len() && band[last].index + 1 == band[last + 1].index {
        last += 1;
    }
    let strays = band[..first].iter().chain(&band[last + 1..]).copied().collect();
    (band[first..=last].to_vec(), strays)
}

/// The lowest speed of `band` at which the down sweep lies above the up
/// sweep: the lowest speed at which the down sweep still holds the upper
/// branch of a softening jump, where it jumps down \[rpm\].
pub(super) fn jump_down_speed(band: &[BandPoint]) -> Option<f64> {
    band.iter().filter(|p| p.down > p.up).map(|p| p.rpm).reduce(f64::min)
}

/// The point of `curve` nearest `rpm`.
pub(super) fn nearest(curve: &Curve, rpm: f64) -> Option<&CurvePoint> {
    curve.points.iter().min_by(|a, b| {
        (rad_per_s_to_rpm(a.speed) - rpm).abs().total_cmp(&(rad_per_s_to_rpm(b.speed) - rpm).abs())
    })
}

/// Whether every value is above zero and none is smaller than the one before
/// it by more than `slack`.
pub(super) fn positive_and_growing(values: &[f64], slack: f64) -> bool {
    !values.is_empty() && values.iter().all(|v| *v > 0.0) && values.windows(2).all(|w| w[1] >= w[0] - slack)
}

/// The peak of `peaks` (rpm, F^(rms)) nearest `rpm`, when it lies within
/// `half_width` \[rpm\] of it.
pub(super) fn peak_within(peaks: &[(f64, f64)], rpm: f64, half_width: f64) -> Option<(f64, f64)> {
    peaks
        .iter()
        .filter(|p| (p.0 - rpm).abs() <= half_width)
        .min_by(|a, b| (a.0 - rpm).abs().total_cmp(&(b.0 - rpm).abs()))
        .copied()
}

/// Whether a worn peak lies more than `apart` (a share of its speed) from
/// every unworn peak.
pub(super) fn is_new(peak: f64, unworn: &[(f64, f64)], apart: f64) -> bool {
    !unworn.iter().any(|q| (q.0 - peak).abs() <= apart * peak)
}

/// The new worn peak (see [`is_new`]) nearest `rpm` within `near` (a
/// share of `rpm`) of it \[rpm\].
pub(super) fn new_peak_near(
    worn: &[(f64, f64)],
    unworn: &[(f64, f64)],
    rpm: f64,
    near: f64,
    apart: f64,
) -> Option<f64> {
    let new: Vec<(f64, f64)> = worn.iter().filter(|p| is_new(p.0, unworn, apart)).copied().collect();
    peak_within(&new, rpm, near * rpm).map(|p| p.0)
}

/// The longest run of consecutive points (rpm, flag) whose flag holds, as
/// its first and last speed \[rpm\]; the first such run on a tie.
pub(super) fn longest_stretch(points: &[(f64, bool)]) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64)> = None;
    let mut start: Option<f64> = None;
    for (i, (rpm, flag)) in points.iter().enumerate() {
        if *flag {
            let from = *start.get_or_insert(*rpm);
            let ends_here = points.get(i + 1).is_none_or(|p| !p.1);
            if ends_here && best.is_none_or(|b| rpm - from > b.1 - b.0) {
                best = Some((from, *rpm));
            }
        } else {
            start = None;
        }
    }
    best
}

/// For each speed of two sweeps in the same direction on the same grid,
/// whether either has separation on either mesh and the worn F^(rms) of
/// the sun–planet mesh exceeds the unworn one by more than `share`.
pub(super) fn worn_excess_where_separating(unworn: &Curve, worn: &Curve, share: f64) -> Vec<(f64, bool)> {
    unworn
        .points
        .iter()
        .zip(&worn.points)
        .map(|(u, w)| {
            let separating = u.separation.iter().chain(&w.separation).any(|s| *s > 0.0);
            (rad_per_s_to_rpm(u.speed), separating && w.rms[0] > (1.0 + share) * u.rms[0])
        })
        .collect()
}

/// Mean F^(rms) of the sun–planet mesh of two curves over the grid indices
/// of `band` \[N\]: (first, second).
pub(super) fn band_means(first: &Curve, second: &Curve, band: &[BandPoint]) -> Option<(f64, f64)> {
    let mean = |c: &Curve| {
        let sum: f64 = band.iter().filter_map(|p| c.points.get(p.index)).map(|p| p.rms[0]).sum();
        sum / band.len() as f64
    };
    (!band.is_empty()).then(|| (mean(first), mean(second)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::response::Direction;
    use crate::scene::units::rpm_to_rad_per_s;

    fn point(index: usize, up: f64, down: f64) -> BandPoint {
        BandPoint { index, rpm: 1000.0 + 100.0 * index as f64, up, down, separation: 0.0 }
    }

    fn curve(rms: &[f64], separation: &[f64]) -> Curve {
        let points = rms
            .iter()
            .zip(separation)
            .enumerate()
            .map(|(i, (f, s))| CurvePoint {
                speed: rpm_to_rad_per_s(1000.0 + 100.0 * i as f64),
                rms: [*f, 0.0],
                separation: [0.0, *s],
            })
            .collect();
        Curve { kappa: 0, direction: Direction::Down, points }
    }

    #[test]
    fn the_band_is_the_contiguous_stretch_of_the_largest_difference_and_a_lone_point_is_a_stray() {
        // Indices 3–6 are one stretch (largest difference at 5); 9 stands alone.
        let band = [
            point(3, 1.0, 1.2),
            point(4, 1.0, 1.5),
            point(5, 1.0, 2.0),
            point(6, 1.0, 1.3),
            point(9, 1.0, 1.9),
        ];
        let (stretch, strays) = contiguous_band(&band);
        assert_eq!(stretch.iter().map(|p| p.index).collect::<Vec<_>>(), [3, 4, 5, 6]);
        assert_eq!(strays.iter().map(|p| p.index).collect::<Vec<_>>(), [9]);
        // A contiguous band has no strays; the lone point with the largest
        // difference is the band and the rest are strays.
        let (stretch, strays) = contiguous_band(&band[..4]);
        assert_eq!((stretch.len(), strays.len()), (4, 0));
        let (stretch, strays) =
            contiguous_band(&[point(3, 1.0, 1.2), point(4, 1.0, 1.2), point(9, 1.0, 3.0)]);
        assert_eq!((stretch[0].index, stretch.len(), strays.len()), (9, 1, 2));
        assert_eq!(contiguous_band(&[]), (Vec::new(), Vec::new()));
    }

    #[test]
    fn the_down_sweep_jumps_down_at_the_lowest_speed_where_it_is_above_the_up_sweep() {
        let band = [point(3, 1.0, 0.8), point(4, 1.0, 1.5), point(5, 1.0, 2.0)];
        assert_eq!(jump_down_speed(&band), Some(1400.0));
        assert_eq!(jump_down_speed(&band[..1]), None);
    }

    #[test]
    fn separation_must_be_positive_and_must_not_fall_by_more_than_the_slack() {
        assert!(positive_and_growing(&[0.05, 0.10, 0.12], 0.0));
        assert!(positive_and_growing(&[0.05, 0.10, 0.095], 1.0 / 60.0));
        assert!(!positive_and_growing(&[0.05, 0.10, 0.05], 1.0 / 60.0));
        assert!(!positive_and_growing(&[0.0, 0.10, 0.12], 1.0 / 60.0));
        assert!(!positive_and_growing(&[], 0.0));
        // Read on a curve: the nearest grid point to 1140 rpm is 1100 rpm.
        let c = curve(&[1.0, 1.0, 1.0], &[0.0, 0.2, 0.1]);
        assert_eq!(nearest(&c, 1140.0).map(|p| p.separation[1]), Some(0.2));
    }

    #[test]
    fn a_peak_counts_near_a_speed_only_within_the_half_width_and_a_new_one_only_away_from_the_old() {
        let peaks = [(2700.0, 5.0), (2900.0, 6.0)];
        assert_eq!(peak_within(&peaks, 2750.0, 50.0), Some((2700.0, 5.0)));
        assert_eq!(peak_within(&peaks, 2800.0, 100.0), Some((2700.0, 5.0)));
        assert_eq!(peak_within(&peaks, 2800.0, 99.0), None);
        let unworn = [(3000.0, 1.0), (7300.0, 1.0)];
        let worn = [(3050.0, 1.0), (3200.0, 1.0), (6900.0, 1.0)];
        // 3050 is within 3 % of the unworn 3000; 3200 is new but 6.7 % from 3000.
        assert_eq!(new_peak_near(&worn, &unworn, 3000.0, 0.05, 0.03), None);
        assert_eq!(new_peak_near(&worn, &unworn, 3000.0, 0.07, 0.03), Some(3200.0));
        // 6900 is 5.5 % from 7300: new, and 1.4 % from 7000.
        assert_eq!(new_peak_near(&worn, &unworn, 7000.0, 0.05, 0.03), Some(6900.0));
    }

    #[test]
    fn the_longest_stretch_spans_its_first_to_its_last_speed_where_the_worn_rise_and_separation_meet() {
        let flags = [
            (1000.0, true),
            (1100.0, false),
            (1200.0, true),
            (1300.0, true),
            (1400.0, true),
            (1500.0, false),
        ];
        assert_eq!(longest_stretch(&flags), Some((1200.0, 1400.0)));
        assert_eq!(longest_stretch(&flags[..2]), Some((1000.0, 1000.0)));
        assert_eq!(longest_stretch(&[(1000.0, false)]), None);
        // The worn curve is 30 % above at every speed, but only the last
        // three separate: the stretch is 1200–1400 rpm.
        let unworn = curve(&[1.0, 1.0, 1.0, 1.0, 1.0], &[0.0, 0.0, 0.1, 0.1, 0.0]);
        let worn = curve(&[1.3, 1.3, 1.3, 1.3, 1.2], &[0.0, 0.0, 0.0, 0.0, 0.1]);
        let flags = worn_excess_where_separating(&unworn, &worn, 0.25);
        assert_eq!(flags.iter().map(|f| f.1).collect::<Vec<_>>(), [false, false, true, true, false]);
        let (a, b) = longest_stretch(&flags).unwrap();
        assert!((a - 1200.0).abs() < 1e-9 && (b - 1300.0).abs() < 1e-9, "{a}–{b}");
        // Band means over indices 2 and 3.
        let band = [point(2, 0.0, 0.0), point(3, 0.0, 0.0)];
        assert_eq!(band_means(&unworn, &worn, &band), Some((1.0, 1.3)));
        assert_eq!(band_means(&unworn, &worn, &[]), None);
    }
}
