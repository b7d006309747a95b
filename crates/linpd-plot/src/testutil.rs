//! Test helpers shared by the modules' tests: unique temporary directories, sample charts and
//! maps, and checks of the files written.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::render::with_ext;
use crate::{LinePlot, PlotError, ScalarMap, Series, SeriesStyle};

/// A fresh, unique temporary directory for one test.
pub(crate) fn temp_dir(name: &str) -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    let dir = std::env::temp_dir().join(format!(
        "linpd-plot-test-{}-{}-{}-{}",
        std::process::id(),
        name,
        COUNTER.fetch_add(1, Ordering::Relaxed),
        nanos
    ));
    assert!(!dir.exists());
    dir
}

/// Removes a test directory unless `LINPD_PLOT_KEEP_TEST_OUTPUT` is set (for inspection).
pub(crate) fn cleanup(dir: &Path) {
    if std::env::var_os("LINPD_PLOT_KEEP_TEST_OUTPUT").is_some() {
        eprintln!("kept {}", dir.display());
    } else {
        std::fs::remove_dir_all(dir).unwrap();
    }
}

/// Width and height from a PNG's IHDR chunk, after checking the signature.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap();
    assert!(bytes.len() > 24, "PNG too short");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG signature");
    assert_eq!(&bytes[12..16], b"IHDR");
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    (w, h)
}

/// `files` are `<stem>.png` of `size` and `<stem>.svg`, whose text has every one of `texts`.
pub(crate) fn check_outputs(files: &[PathBuf], stem: &Path, size: (u32, u32), texts: &[&str]) {
    assert_eq!(files, &[with_ext(stem, "png"), with_ext(stem, "svg")]);
    for f in files {
        assert!(f.is_file(), "{} missing", f.display());
    }
    assert_eq!(png_size(&files[0]), size);
    let svg = std::fs::read_to_string(&files[1]).unwrap();
    assert!(svg.contains("<svg"), "no <svg element");
    for t in texts {
        assert!(svg.contains(t), "SVG lacks text {t:?}");
    }
}

/// The plotting function's result is [`PlotError::InvalidData`] with `needle` in its message.
pub(crate) fn assert_invalid(r: Result<Vec<PathBuf>, PlotError>, needle: &str) {
    match r {
        Err(PlotError::InvalidData(msg)) => {
            assert!(msg.contains(needle), "message {msg:?} lacks {needle:?}")
        }
        other => panic!("expected InvalidData, got {other:?}"),
    }
}

/// Three labelled series on [0, 1], one in each style.
pub(crate) fn sample_plot() -> LinePlot {
    let x: Vec<f64> = (0..50).map(|i| i as f64 / 49.0).collect();
    LinePlot::new("Test title alpha", "position x", "displacement u")
        .with_series(Series::new("sine", x.clone(), x.iter().map(|v| (6.0 * v).sin()).collect()))
        .with_series(
            Series::new("square", x.clone(), x.iter().map(|v| v * v).collect()).with_style(SeriesStyle::Markers),
        )
        .with_series(
            Series::new("cubic", x.clone(), x.iter().map(|v| v * v * v).collect()).with_style(SeriesStyle::LineMarkers),
        )
}

/// A smooth field on `nx x ny` cells over `[0, 2] x [-1, 1]`.
pub(crate) fn sample_map(nx: usize, ny: usize) -> ScalarMap {
    let values = (0..nx * ny)
        .map(|k| {
            let (ix, iy) = (k % nx, k / nx);
            (ix as f64 * 0.3).sin() + iy as f64 * 0.1
        })
        .collect();
    ScalarMap {
        title: "Map title beta".into(),
        x_label: "x coord".into(),
        y_label: "y coord".into(),
        nx,
        ny,
        x_range: (0.0, 2.0),
        y_range: (-1.0, 1.0),
        values,
        value_label: "strain energy".into(),
        empty: Vec::new(),
        equal_aspect: false,
    }
}
