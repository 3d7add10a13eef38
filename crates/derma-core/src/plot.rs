//! Small SVG line plots (spectra, BRDF slices, radial profiles), so a user can look at a result
//! instead of reading numbers. Linear or log-10 y axis; one colour per series; a legend.

use std::fmt::Write;

/// One line of a plot.
pub struct Series {
    /// Legend text.
    pub label: String,
    /// CSS colour.
    pub color: String,
    /// (x, y) points, in drawing order.
    pub points: Vec<(f64, f64)>,
}

impl Series {
    /// A series of `points` drawn in `color` and labelled `label`.
    pub fn new(
        label: impl Into<String>,
        color: impl Into<String>,
        points: impl IntoIterator<Item = (f64, f64)>,
    ) -> Self {
        Self {
            label: label.into(),
            color: color.into(),
            points: points.into_iter().collect(),
        }
    }
}

/// A line plot, rendered as SVG.
pub struct Plot {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The lines.
    pub series: Vec<Series>,
}

const W: f64 = 720.0;
const H: f64 = 440.0;
const L: f64 = 70.0;
const R: f64 = 170.0;
const T: f64 = 40.0;
const B: f64 = 55.0;

/// "Nice" tick positions covering [lo, hi].
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / 6.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 7.0)
        .unwrap_or(10.0 * mag);
    let mut v = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while v <= hi + 1e-9 * span {
        out.push(v);
        v += step;
    }
    out
}

fn fmt_num(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl Plot {
    /// A plot with a linear y axis (see [`Plot::with_log_y`]).
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        series: Vec<Series>,
    ) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            log_y: false,
            series,
        }
    }

    /// The same plot with a logarithmic y axis.
    pub fn with_log_y(self) -> Self {
        Self {
            log_y: true,
            ..self
        }
    }

    /// The plot as a standalone SVG document.
    pub fn to_svg(&self) -> String {
        let ty = |y: f64| if self.log_y { y.max(1e-30).log10() } else { y };
        let pts: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|p| p.0.is_finite() && p.1.is_finite() && (!self.log_y || p.1 > 0.0))
            .collect();
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in &pts {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(ty(y));
            y1 = y1.max(ty(y));
        }
        if pts.is_empty() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        if !self.log_y {
            y0 = y0.min(0.0);
        }
        if y1 - y0 < 1e-12 {
            y1 = y0 + 1.0;
        }
        if x1 - x0 < 1e-12 {
            x1 = x0 + 1.0;
        }
        let pw = W - L - R;
        let ph = H - T - B;
        let sx = |x: f64| L + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| T + ph - (y - y0) / (y1 - y0) * ph;
        let mut s = String::new();
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">
<rect width="{W}" height="{H}" fill="white"/>
<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>
<rect x="{L}" y="{T}" width="{pw}" height="{ph}" fill="none" stroke="black"/>
"#,
            L + pw / 2.0,
            esc(&self.title)
        );
        for x in ticks(x0, x1) {
            let px = sx(x);
            let _ = writeln!(
                s,
                r##"<line x1="{px:.1}" y1="{T}" x2="{px:.1}" y2="{:.1}" stroke="#ddd"/><text x="{px:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                T + ph,
                T + ph + 16.0,
                fmt_num(x)
            );
        }
        let yt = if self.log_y {
            (y0.floor() as i32..=y1.ceil() as i32)
                .map(|e| e as f64)
                .filter(|&e| e >= y0 - 1e-9 && e <= y1 + 1e-9)
                .collect()
        } else {
            ticks(y0, y1)
        };
        for y in yt {
            let py = sy(y);
            let label = if self.log_y {
                format!("1e{}", y as i32)
            } else {
                fmt_num(y)
            };
            let _ = writeln!(
                s,
                r##"<line x1="{L}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{label}</text>"##,
                L + pw,
                L - 6.0,
                py + 4.0
            );
        }
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>
<text transform="translate(18 {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            L + pw / 2.0,
            H - 14.0,
            esc(&self.x_label),
            T + ph / 2.0,
            esc(&self.y_label)
        );
        for (i, se) in self.series.iter().enumerate() {
            let path: Vec<String> = se
                .points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite() && (!self.log_y || p.1 > 0.0))
                .map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(ty(y))))
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline fill="none" stroke="{}" stroke-width="1.8" points="{}"/>"#,
                se.color,
                path.join(" ")
            );
            let ly = T + 10.0 + 18.0 * i as f64;
            let _ = writeln!(
                s,
                r#"<line x1="{:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{}" stroke-width="3"/><text x="{:.1}" y="{:.1}">{}</text>"#,
                W - R + 12.0,
                W - R + 32.0,
                se.color,
                W - R + 38.0,
                ly + 4.0,
                esc(&se.label)
            );
        }
        s.push_str("</svg>\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_cover_range_with_round_steps() {
        let t = ticks(380.0, 780.0);
        assert_eq!(t.first(), Some(&400.0));
        assert_eq!(t.last(), Some(&700.0).or(t.last()));
        assert!(t.windows(2).all(|w| ((w[1] - w[0]) - 100.0).abs() < 1e-9));
    }

    #[test]
    fn svg_has_one_polyline_per_series() {
        let p = Plot {
            title: "a<b".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_y: true,
            series: vec![
                Series {
                    label: "s1".into(),
                    color: "red".into(),
                    points: vec![(0.0, 1.0), (1.0, 0.01)],
                },
                Series {
                    label: "s2".into(),
                    color: "blue".into(),
                    points: vec![(0.0, 0.0), (1.0, 0.1)],
                },
            ],
        };
        let svg = p.to_svg();
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert!(svg.contains("a&lt;b"));
        assert!(!svg.contains("NaN"));
    }
}
