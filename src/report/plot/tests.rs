//! Unit tests for the chart writer.

use super::*;
use std::fs;

const PNG_MAGIC: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];

fn sample_chart() -> Chart {
    let x: Vec<f64> = (0..200).map(|i| f64::from(i) * 0.05).collect();
    Chart {
        title: "Mesh force versus time".to_string(),
        x_label: "Time [s]".to_string(),
        y_label: "Force [N]".to_string(),
        series: vec![
            Series::new("sun-planet", x.clone(), x.iter().map(|t| t.sin() * 100.0).collect()),
            Series::new("ring-planet", x.clone(), x.iter().map(|t| t.cos() * 80.0).collect())
                .with_style(SeriesStyle::LineAndPoints),
            Series::new(
                "measured",
                x.iter().step_by(10).copied().collect(),
                x.iter().step_by(10).map(|t| (t * 1.3).sin() * 60.0).collect(),
            )
            .with_style(SeriesStyle::Points),
        ],
        vlines: vec![(2.5, "fault onset".to_string()), (7.0, "shutdown".to_string())],
    }
}

fn read(path: &Path) -> Vec<u8> {
    fs::read(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

#[test]
fn writes_svg_and_png_for_three_series() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("forces");
    let paths = write_chart(&sample_chart(), &stem).unwrap();
    assert_eq!(paths, vec![dir.path().join("forces.svg"), dir.path().join("forces.png")]);

    let svg = String::from_utf8(read(&paths[0])).unwrap();
    assert!(svg.starts_with("<svg"), "not an SVG document");
    for text in [
        "Mesh force versus time",
        "Time [s]",
        "Force [N]",
        "sun-planet",
        "ring-planet",
        "measured",
        "fault onset",
        "shutdown",
    ] {
        assert!(svg.contains(text), "SVG lacks {text:?}");
    }

    let png = read(&paths[1]);
    assert!(png.len() > 1000, "PNG suspiciously small: {} bytes", png.len());
    assert_eq!(png[..8], PNG_MAGIC);

    // Only the two outputs remain: no temporary files are left behind.
    let mut names: Vec<String> = fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["forces.png", "forces.svg"]);
}

#[test]
fn overwrites_existing_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("again");
    fs::write(dir.path().join("again.svg"), "old").unwrap();
    fs::write(dir.path().join("again.png"), "old").unwrap();
    let paths = write_chart(&sample_chart(), &stem).unwrap();
    assert!(read(&paths[0]).starts_with(b"<svg"));
    assert_eq!(read(&paths[1])[..8], PNG_MAGIC);
}

#[test]
fn stem_with_dot_keeps_its_name() {
    let dir = tempfile::tempdir().unwrap();
    let paths = write_chart(&sample_chart(), &dir.path().join("run.v2")).unwrap();
    assert_eq!(paths[0], dir.path().join("run.v2.svg"));
    assert_eq!(paths[1], dir.path().join("run.v2.png"));
}

#[test]
fn constant_and_single_point_series_render() {
    let dir = tempfile::tempdir().unwrap();
    let chart = Chart {
        title: "Constant".to_string(),
        series: vec![
            Series::new("flat", vec![1.0, 2.0, 3.0], vec![5.0, 5.0, 5.0]),
            Series::new("dot", vec![2.0], vec![5.0]).with_style(SeriesStyle::Points),
        ],
        ..Chart::default()
    };
    write_chart(&chart, &dir.path().join("flat")).unwrap();

    let zero = Chart { series: vec![Series::new("zero", vec![0.0], vec![0.0])], ..Chart::default() };
    write_chart(&zero, &dir.path().join("zero")).unwrap();
}

#[test]
fn many_series_and_extreme_values_render() {
    let dir = tempfile::tempdir().unwrap();
    let series = (0..12)
        .map(|i| {
            let k = f64::from(i);
            Series::new(format!("s{i}"), vec![0.0, 1e-9, 2e-9], vec![k * 1e12, -k * 1e12, k])
        })
        .collect();
    let chart = Chart { title: "Many".to_string(), series, ..Chart::default() };
    write_chart(&chart, &dir.path().join("many")).unwrap();
}

#[test]
fn huge_and_tiny_values_render() {
    let dir = tempfile::tempdir().unwrap();
    for (name, x, y) in [
        ("big", vec![-8e307, 8e307], vec![f64::MAX, f64::MAX / 2.0]),
        ("tiny", vec![0.0, 1e-310], vec![5e-324, -5e-324]),
        ("offset", vec![1e16, 1e16 + 2.0], vec![1.0, 1.0 + 1e-15]),
    ] {
        let chart = Chart { series: vec![Series::new(name, x, y)], ..Chart::default() };
        write_chart(&chart, &dir.path().join(name)).unwrap();
    }
}

#[test]
fn unrepresentable_span_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let chart = Chart {
        series: vec![Series::new("huge", vec![0.0, 1.0], vec![-f64::MAX, f64::MAX])],
        ..Chart::default()
    };
    let err = write_chart(&chart, &dir.path().join("huge")).unwrap_err();
    assert!(matches!(err, PlotError::RangeTooLarge { axis: "y" }), "{err:?}");
}

#[test]
fn padded_range_is_never_empty() {
    for values in [
        vec![3.0, 3.0],
        vec![0.0],
        vec![-2.0, 4.0],
        vec![1e-300, 1e-300],
        vec![5e-324],
        vec![f64::MAX],
        vec![-f64::MAX, 0.0],
        vec![1e16, 1e16 + 2.0],
    ] {
        let r = padded_range(values.iter().copied()).unwrap();
        assert!(r.start < r.end && (r.end - r.start).is_finite(), "{values:?} gave {r:?}");
        assert!(values.iter().all(|v| r.contains(v) || *v == r.end), "{values:?} not in {r:?}");
    }
    let r = padded_range([0.0, 10.0].into_iter()).unwrap();
    assert!((r.start + 0.5).abs() < 1e-12 && (r.end - 10.5).abs() < 1e-12, "{r:?}");
    assert_eq!(padded_range(std::iter::empty()), Some(0.0..1.0));
    assert_eq!(padded_range([-f64::MAX, f64::MAX].into_iter()), None);
}

#[test]
fn tick_labels_are_short() {
    assert_eq!(format_tick(0.30000000000000004, &(0.0..1.0)), "0.3");
    assert_eq!(format_tick(0.15, &(0.0..0.5)), "0.15");
    assert_eq!(format_tick(250.0, &(0.0..1000.0)), "250");
    assert_eq!(format_tick(-250.0, &(-1000.0..0.0)), "-250");
    assert_eq!(format_tick(-0.0001, &(-1.0..1.0)), "0.0");
    assert_eq!(format_tick(0.0, &(-1.0..1.0)), "0");
    assert_eq!(format_tick(2.5e7, &(0.0..3e7)), "2.5e7");
    assert_eq!(format_tick(-4e7, &(-1e8..0.0)), "-4e7");
    assert_eq!(format_tick(3e7, &(0.0..1e8)), "3e7");
    assert_eq!(format_tick(1.5e-9, &(0.0..1e-9)), "1.5e-9");
    assert_eq!(format_tick(1e16 + 4.0, &(1e16..1e16 + 20.0)), "1.0000000000000004e16");
}

#[test]
fn empty_chart_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("empty");
    let no_series = Chart::default();
    assert!(matches!(write_chart(&no_series, &stem), Err(PlotError::EmptyChart)));
    let no_points = Chart { series: vec![Series::new("nothing", vec![], vec![])], ..Chart::default() };
    assert!(matches!(write_chart(&no_points, &stem), Err(PlotError::EmptyChart)));
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn length_mismatch_names_the_series() {
    let dir = tempfile::tempdir().unwrap();
    let mut chart = sample_chart();
    chart.series[1].y.pop();
    let err = write_chart(&chart, &dir.path().join("bad")).unwrap_err();
    match &err {
        PlotError::LengthMismatch { series, x_len, y_len } => {
            assert_eq!(series, "ring-planet");
            assert_eq!((*x_len, *y_len), (200, 199));
        }
        other => panic!("unexpected error {other:?}"),
    }
    assert!(err.to_string().contains("ring-planet"));
}

#[test]
fn non_finite_value_names_series_and_index() {
    let dir = tempfile::tempdir().unwrap();
    let mut chart = sample_chart();
    chart.series[2].y[3] = f64::NAN;
    let err = write_chart(&chart, &dir.path().join("bad")).unwrap_err();
    match &err {
        PlotError::NonFinite { series, axis, index, value } => {
            assert_eq!(series, "measured");
            assert_eq!(*axis, "y");
            assert_eq!(*index, 3);
            assert!(value.is_nan());
        }
        other => panic!("unexpected error {other:?}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("measured") && msg.contains("index 3"), "{msg}");

    let mut chart = sample_chart();
    chart.series[0].x[7] = f64::INFINITY;
    assert!(matches!(
        write_chart(&chart, &dir.path().join("bad")),
        Err(PlotError::NonFinite { axis: "x", index: 7, .. })
    ));
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn non_finite_marker_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut chart = sample_chart();
    chart.vlines.push((f64::NEG_INFINITY, "never".to_string()));
    match write_chart(&chart, &dir.path().join("bad")).unwrap_err() {
        PlotError::NonFiniteMarker { label, index, .. } => {
            assert_eq!(label, "never");
            assert_eq!(index, 2);
        }
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn stem_without_file_name_is_an_error() {
    assert!(matches!(write_chart(&sample_chart(), Path::new("/")), Err(PlotError::InvalidStem { .. })));
    assert!(matches!(write_chart(&sample_chart(), Path::new("")), Err(PlotError::InvalidStem { .. })));
}

#[test]
fn missing_directory_is_an_io_error_with_path() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("no-such-dir").join("chart");
    match write_chart(&sample_chart(), &stem).unwrap_err() {
        PlotError::Io { path, source } => {
            assert!(path.starts_with(dir.path().join("no-such-dir")), "{}", path.display());
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn backend_error_is_reported_as_text() {
    let err = backend_err(DrawingAreaErrorKind::<std::io::Error>::LayoutError);
    assert!(matches!(&err, PlotError::Backend(msg) if !msg.is_empty()));
    assert!(err.to_string().starts_with("plotting backend error"));
}
