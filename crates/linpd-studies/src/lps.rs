//! `linpd study lps-tension-bar`: a 3D LPS tension bar against classical elasticity
//! (E = 9KG/(3K + G), nu = (3K - 2G)/(2(3K + G))): elongation and lateral contraction versus
//! grid refinement and delta/h, with and without the bulk-weighted-volume surface correction.

use crate::lps_tension::{tension_bar, TensionBar};
use crate::out::{write, Cases};
use crate::StudyError;
use linpd_core::progress::Progress;
use linpd_lps::{Influence, SurfaceCorrection};
use linpd_plot::{line_plot, LinePlot, Series, SeriesStyle};
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// Runs the study into `dir`.
pub(crate) fn run(dir: &Path, report: &mut dyn Write, progress: &dyn Progress) -> Result<(), StudyError> {
    let cases = Cases::new(progress, "lps-tension-bar", 9);
    let mut rows = Vec::new();
    let mut series = Vec::new();
    writeln!(
        report,
        "{:>7} {:>6} {:>12} {:>10} {:>12} {:>10} {:>9}",
        "h", "d/h", "correction", "unknowns", "elong. err", "nu_eff", "time s"
    )?;
    for (ratio, surface, label) in [
        (2.0, SurfaceCorrection::None, "delta = 2h"),
        (3.0, SurfaceCorrection::None, "delta = 3h"),
        (3.0, SurfaceCorrection::BulkWeightedVolume, "delta = 3h, bulk m0"),
    ] {
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for h in [0.125, 0.0833333333333333, 0.0625] {
            cases.next(format_args!("{label}, h = {h:.4}"));
            let bar = TensionBar {
                length: 1.0,
                width: 0.5,
                spacing: h,
                horizon_ratio: ratio,
                bulk: 2.0,
                shear: 1.0,
                sigma: 1e-3,
                influence: Influence::InverseDistance,
                surface,
            };
            let r = tension_bar(&bar)?;
            let err = r.elongation / r.elongation_classical - 1.0;
            writeln!(
                report,
                "{h:>7.4} {ratio:>6} {:>12} {:>10} {:>11.2}% {:>10.3} {:>9.2}",
                if surface == SurfaceCorrection::None { "none" } else { "bulk m0" },
                r.unknowns,
                100.0 * err,
                r.poisson_effective,
                r.solve_seconds
            )?;
            rows.push(json!({"h": h, "horizon_ratio": ratio, "correction": format!("{surface:?}"), "unknowns": r.unknowns,
                "elongation": r.elongation, "elongation_classical": r.elongation_classical, "relative_error": err,
                "poisson_effective": r.poisson_effective, "poisson_classical": r.poisson_classical, "solve_seconds": r.solve_seconds}));
            xs.push(h);
            ys.push(100.0 * err);
        }
        series.push(Series { label: label.into(), x: xs, y: ys, style: SeriesStyle::LineMarkers, color: None });
    }
    write(dir, &json!({"study": "lps-tension-bar", "rows": rows}))?;
    let plot = LinePlot {
        title: "LPS tension bar (L = 1, W = 0.5, K = 2, G = 1): elongation error vs classical".into(),
        x_label: "spacing h".into(),
        y_label: "elongation error (%)".into(),
        series,
        log_x: false,
        log_y: false,
        equal_aspect: false,
    };
    line_plot(&plot, &dir.join("elongation_error")).map(|_| ()).map_err(StudyError::from)
}
