//! A report's files: `report.md`, a CSV per series and an SVG plot of each, and the
//! sweep's log–log plots.

use super::*;

pub(super) fn write_outputs(r: &Report) -> Result<(), ValidateError> {
    let io = |what: String| move |source| ValidateError::Io { what, source };
    let md = r.out.join("report.md");
    std::fs::write(&md, r.markdown()).map_err(io(format!("writing {}", md.display())))?;
    for s in &r.series {
        let mut csv = format!("{},{}\n", s.x_label, s.y_label);
        for (x, y) in &s.points {
            let _ = writeln!(csv, "{x:e},{y:e}");
        }
        let path = r.out.join(format!("{}.csv", s.name));
        std::fs::write(&path, csv).map_err(io(format!("writing {}", path.display())))?;
        let path = r.out.join(format!("{}.svg", s.name));
        std::fs::write(&path, svg_plot(s)).map_err(io(format!("writing {}", path.display())))?;
    }
    Ok(())
}

/// A line plot of `s.points` with `s.reference` as markers, axes from zero.
pub(super) fn svg_plot(s: &Series) -> String {
    let (w, h, m) = (640.0, 420.0, 60.0);
    let all = s.points.iter().chain(&s.reference);
    let x_max = all.clone().map(|p| p.0).fold(0.0, f64::max).max(1e-30);
    let y_max = all.map(|p| p.1).fold(0.0, f64::max).max(1e-30);
    let px = |x: f64| m + (w - 2.0 * m) * x / x_max;
    let py = |y: f64| h - m - (h - 2.0 * m) * y / y_max;
    let mut t = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <line x1=\"{m}\" y1=\"{b}\" x2=\"{r}\" y2=\"{b}\" stroke=\"black\"/><line x1=\"{m}\" y1=\"{m}\" x2=\"{m}\" y2=\"{b}\" stroke=\"black\"/>\n\
         <text x=\"{cx}\" y=\"{tb}\" text-anchor=\"middle\">{xl} (0 … {x_max:.3})</text>\n\
         <text x=\"14\" y=\"{cy}\" transform=\"rotate(-90 14 {cy})\" text-anchor=\"middle\">{yl} (0 … {y_max:.3})</text>\n\
         <text x=\"{cx}\" y=\"24\" text-anchor=\"middle\">{name}: line = couplet, circles = reference</text>\n",
        b = h - m,
        r = w - m,
        cx = w / 2.0,
        tb = h - 20.0,
        cy = h / 2.0,
        xl = s.x_label,
        yl = s.y_label,
        name = s.name,
    );
    let path: Vec<String> = s
        .points
        .iter()
        .map(|(x, y)| format!("{:.1},{:.1}", px(*x), py(*y)))
        .collect();
    let _ = writeln!(
        t,
        "<polyline fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"2\" points=\"{}\"/>",
        path.join(" ")
    );
    for (x, y) in &s.reference {
        let _ = writeln!(
            t,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"4\" fill=\"none\" stroke=\"#d62728\"/>",
            px(*x),
            py(*y)
        );
    }
    t + "</svg>\n"
}

/// A sweep's error against a cost `x` (wall time, particle count), both axes logarithmic
/// since the points span decades in each: one line per scheme through its spacings in
/// order of cost, each point labelled with its δ, and a legend. A point without an error
/// (its run failed, or it measured nothing) is not on the line: it is named under the
/// legend, so that the plot does not look complete when it is not.
pub(super) fn sweep_svg(
    title: &str,
    x_label: &str,
    points: &[SweepPoint],
    x: impl Fn(&SweepPoint) -> f64,
) -> String {
    const COLOURS: [&str; 6] = [
        "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
    ];
    let (w, h, left, right, top, bottom) = (960.0, 440.0, 70.0, 400.0, 40.0, 50.0);
    let error = |p: &SweepPoint| p.headline.as_ref().map_or(f64::NAN, |h| h.1);
    // On a log axis: positive and finite (NaN fails both).
    let plotted = |p: &&SweepPoint| {
        p.failure.is_none()
            && error(p) > 0.0
            && error(p) < f64::INFINITY
            && x(p) > 0.0
            && x(p) < f64::INFINITY
    };
    let good: Vec<&SweepPoint> = points.iter().filter(plotted).collect();
    // Whole decades around the data, so that the ticks are 10^k.
    let decades = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
            (a.min(y.log10()), b.max(y.log10()))
        });
        if lo.is_finite() {
            (lo.floor(), hi.ceil().max(lo.floor() + 1.0))
        } else {
            (0.0, 1.0)
        }
    };
    let (x0, x1) = decades(&mut good.iter().map(|p| x(p)));
    let (y0, y1) = decades(&mut good.iter().map(|p| error(p)));
    let px = |v: f64| left + (w - left - right) * (v.log10() - x0) / (x1 - x0);
    let py = |v: f64| h - bottom - (h - top - bottom) * (v.log10() - y0) / (y1 - y0);
    let (xb, yb) = (h - bottom, w - right);
    let mut t = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"{cx}\" y=\"20\" text-anchor=\"middle\">{title}</text>\n\
         <line x1=\"{left}\" y1=\"{xb}\" x2=\"{yb}\" y2=\"{xb}\" stroke=\"black\"/><line x1=\"{left}\" y1=\"{top}\" x2=\"{left}\" y2=\"{xb}\" stroke=\"black\"/>\n\
         <text x=\"{cx}\" y=\"{tb}\" text-anchor=\"middle\">{x_label} (log)</text>\n\
         <text x=\"16\" y=\"{cy}\" transform=\"rotate(-90 16 {cy})\" text-anchor=\"middle\">error (log)</text>\n",
        cx = (left + yb) / 2.0,
        tb = h - 12.0,
        cy = (top + xb) / 2.0,
    );
    for k in x0 as i32..=x1 as i32 {
        let v = 10f64.powi(k);
        let _ = writeln!(
            t,
            "<line x1=\"{0:.1}\" y1=\"{xb}\" x2=\"{0:.1}\" y2=\"{1}\" stroke=\"black\"/><text x=\"{0:.1}\" y=\"{2}\" text-anchor=\"middle\">1e{k}</text>",
            px(v),
            xb + 5.0,
            xb + 18.0
        );
    }
    for k in y0 as i32..=y1 as i32 {
        let v = 10f64.powi(k);
        let _ = writeln!(
            t,
            "<line x1=\"{0}\" y1=\"{1:.1}\" x2=\"{left}\" y2=\"{1:.1}\" stroke=\"black\"/><text x=\"{2}\" y=\"{3:.1}\" text-anchor=\"end\">{4}</text>",
            left - 5.0,
            py(v),
            left - 7.0,
            py(v) + 4.0,
            pct(v)
        );
    }
    let mut schemes: Vec<&str> = Vec::new();
    for p in points {
        if !schemes.contains(&p.scheme.as_str()) {
            schemes.push(&p.scheme);
        }
    }
    for (i, scheme) in schemes.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let mut line: Vec<&&SweepPoint> = good.iter().filter(|p| p.scheme == *scheme).collect();
        line.sort_by(|a, b| x(a).total_cmp(&x(b)));
        let path: Vec<String> = line
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(x(p)), py(error(p))))
            .collect();
        let _ = writeln!(
            t,
            "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"2\" points=\"{}\"/>",
            path.join(" ")
        );
        for p in &line {
            let (cx, cy) = (px(x(p)), py(error(p)));
            let _ = writeln!(
                t,
                "<circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"4\" fill=\"{c}\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\">δ = {:e}</text>",
                cx + 6.0,
                cy - 6.0,
                p.spacing
            );
        }
        let ly = top + 18.0 * i as f64;
        let _ = writeln!(
            t,
            "<line x1=\"{0}\" y1=\"{ly}\" x2=\"{1}\" y2=\"{ly}\" stroke=\"{c}\" stroke-width=\"2\"/><text x=\"{2}\" y=\"{3}\" font-size=\"11\">{scheme}</text>",
            yb + 12.0,
            yb + 32.0,
            yb + 36.0,
            ly + 4.0
        );
    }
    let mut ly = top + 18.0 * schemes.len() as f64 + 10.0;
    for p in points.iter().filter(|p| !plotted(p)) {
        let why = p
            .failure
            .as_deref()
            .map_or("no error measured", |_| "run failed");
        let _ = writeln!(
            t,
            "<text x=\"{0}\" y=\"{ly}\" font-size=\"10\">not plotted ({why}): {1}, δ = {2:e}</text>",
            yb + 12.0,
            p.scheme,
            p.spacing
        );
        ly += 14.0;
    }
    t + "</svg>\n"
}
