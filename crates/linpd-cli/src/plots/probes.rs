//! The plots of a line probe ([`linpd_problem::probe`]): the displacement components along the
//! segment (`<name>_u`) and, when the solution has stresses, the stress components and von
//! Mises (`<name>_stress`), over the distance `s` from the probe's start. Points outside the
//! body break the curves.

use super::AXES;
use linpd_plot::{line_plot, LinePlot, PlotError, Series};
use linpd_problem::ProbeSamples;
use std::path::{Path, PathBuf};

/// The plots of `p`, a probe of the scene `scene` (none if no point is inside the body).
pub fn probe_plots(scene: &str, p: &ProbeSamples, dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    let d = p.dim;
    let ends = |x: &[f64; 3]| x[..d].iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(", ");
    let title = |what: &str| {
        format!("{scene}: {what} along {} ([{}] to [{}])", p.probe.name, ends(&p.probe.from), ends(&p.probe.to))
    };
    let x_label = "s (distance from the start)";
    let mut files = Vec::new();
    let u_plot = LinePlot {
        series: (0..d).flat_map(|a| runs(&format!("u_{}", AXES[a]), a, &p.s, &p.inside, &|k| p.u[d * k + a])).collect(),
        ..LinePlot::new(title("displacement"), x_label, "u")
    };
    if u_plot.series.is_empty() {
        return Ok(files);
    }
    files.extend(line_plot(&u_plot, &dir.join(format!("{}_u", p.probe.name)))?);
    if let Some(stress) = &p.stress {
        let mut series = Vec::new();
        let voigt = linpd_problem::fields::voigt_labels(d);
        for (c, label) in voigt.iter().enumerate() {
            series.extend(runs(&format!("sigma_{label}"), c, &p.s, &p.inside, &|k| {
                linpd_problem::fields::voigt_of(d, &stress[k])[c]
            }));
        }
        let von_mises = |k| p.von_mises(k).unwrap_or(f64::NAN);
        series.extend(runs("von_mises", voigt.len(), &p.s, &p.inside, &von_mises));
        let plot = LinePlot { series, ..LinePlot::new(title("stress"), x_label, "stress") };
        files.extend(line_plot(&plot, &dir.join(format!("{}_stress", p.probe.name)))?);
    }
    Ok(files)
}

/// `value(k)` over `s` as one series per run of inside points, all in palette colour `color`
/// and labelled once.
fn runs(label: &str, color: usize, s: &[f64], inside: &[bool], value: &dyn Fn(usize) -> f64) -> Vec<Series> {
    let mut out: Vec<Series> = Vec::new();
    let mut k = 0;
    while k < s.len() {
        if !inside[k] {
            k += 1;
            continue;
        }
        let start = k;
        while k < s.len() && inside[k] {
            k += 1;
        }
        let name = if out.is_empty() { label } else { "" };
        out.push(Series::new(name, s[start..k].to_vec(), (start..k).map(value).collect()).with_color(color));
    }
    out
}
