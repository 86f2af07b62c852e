//! Issue 33: every kind of figure djkr writes, made by the command that writes it (small inputs),
//! read back from its SVG: no data marker, line vertex, line segment or filled band lies under a
//! legend box, and every axis label ends with its unit.
//!
//! What the SVG holds (plotters' SVG backend, as djkr's plot layer uses it): a legend box is a
//! `<rect>` filled white at opacity 0.88 followed by its frame and its entries; markers are
//! `<circle cx cy>` or `<polygon>`; lines are `<polyline>`; the band of a dense line is a
//! `<polygon>`; text is `<text font-size ...>CONTENT</text>`, a title in the figure's largest
//! font. The data a legend could hide are the elements drawn before its box; what follows it
//! inside it is its own entries (other panels lie in other cells).
//!
//! `DJKR_SVG_DIR=DIR cargo test --release --test cli figure_svg::check_a_folder -- --ignored` applies
//! the same checks to every SVG under DIR (e.g. the figures of an older build, which fail them).

use std::path::{Path, PathBuf};
use std::process::Command;

fn djkr(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("djkr runs");
    assert!(
        o.status.success(),
        "djkr {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[derive(Debug, Clone, Copy)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn contains(&self, (x, y): (f64, f64)) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }

    /// True when the segment a–b passes through the box (Liang–Barsky).
    fn crossed_by(&self, a: (f64, f64), b: (f64, f64)) -> bool {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
        for (p, q) in [
            (-dx, a.0 - self.x0),
            (dx, self.x1 - a.0),
            (-dy, a.1 - self.y0),
            (dy, self.y1 - a.1),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else if p < 0.0 {
                t0 = t0.max(q / p);
            } else {
                t1 = t1.min(q / p);
            }
        }
        t0 <= t1
    }
}

#[derive(Debug, Clone)]
enum Elem {
    Legend(Rect),
    Circle((f64, f64)),
    /// A polyline (`closed` false) or polygon.
    Path {
        points: Vec<(f64, f64)>,
        closed: bool,
    },
    Text {
        at: (f64, f64),
        size: f64,
        text: String,
    },
}

fn attrs(tag: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = tag;
    while let Some(eq) = rest.find("=\"") {
        let name = rest[..eq]
            .rsplit(|c: char| c.is_whitespace())
            .next()
            .unwrap_or("")
            .to_string();
        let after = &rest[eq + 2..];
        let end = after.find('"').unwrap_or(after.len());
        out.push((name, after[..end].to_string()));
        rest = &after[(end + 1).min(after.len())..];
    }
    out
}

fn attr(a: &[(String, String)], name: &str) -> Option<f64> {
    a.iter()
        .find(|(n, _)| n == name)
        .and_then(|(_, v)| v.parse().ok())
}

fn text_attr<'a>(a: &'a [(String, String)], name: &str) -> &'a str {
    a.iter()
        .find(|(n, _)| n == name)
        .map_or("", |(_, v)| v.as_str())
}

fn points(s: &str) -> Vec<(f64, f64)> {
    s.split_whitespace()
        .filter_map(|p| {
            let (x, y) = p.split_once(',')?;
            Some((x.parse().ok()?, y.parse().ok()?))
        })
        .collect()
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// The elements of an SVG written by djkr's plot layer, in document order.
fn parse(svg: &str) -> Vec<Elem> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        rest = &rest[start + 1..];
        let end = rest.find('>').unwrap_or(rest.len());
        let tag = &rest[..end];
        let name = tag.split_whitespace().next().unwrap_or("");
        let a = attrs(tag);
        match name {
            "rect"
                if text_attr(&a, "fill") == "#FFFFFF"
                    && attr(&a, "opacity").is_some_and(|o| o < 1.0) =>
            {
                let (x, y) = (attr(&a, "x").unwrap(), attr(&a, "y").unwrap());
                let (w, h) = (attr(&a, "width").unwrap(), attr(&a, "height").unwrap());
                out.push(Elem::Legend(Rect {
                    x0: x,
                    y0: y,
                    x1: x + w,
                    y1: y + h,
                }));
            }
            "circle" => out.push(Elem::Circle((
                attr(&a, "cx").unwrap(),
                attr(&a, "cy").unwrap(),
            ))),
            "polyline" | "polygon" => out.push(Elem::Path {
                points: points(text_attr(&a, "points")),
                closed: name == "polygon",
            }),
            "text" => {
                let body = &rest[end + 1..];
                let close = body.find("</text>").unwrap_or(0);
                out.push(Elem::Text {
                    at: (attr(&a, "x").unwrap(), attr(&a, "y").unwrap()),
                    size: attr(&a, "font-size").unwrap(),
                    text: unescape(body[..close].trim()),
                });
            }
            _ => {}
        }
        rest = &rest[end.min(rest.len())..];
    }
    out
}

/// Even–odd point-in-polygon.
fn inside_polygon(p: (f64, f64), poly: &[(f64, f64)]) -> bool {
    let mut inside = false;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + poly.len() - 1) % poly.len()]);
        if (a.1 > p.1) != (b.1 > p.1) && p.0 < (b.0 - a.0) * (p.1 - a.1) / (b.1 - a.1) + a.0 {
            inside = !inside;
        }
    }
    inside
}

/// The units an axis may be labelled in: SI with the prefixes djkr uses, radians, and "–" for
/// a dimensionless quantity.
fn is_unit(u: &str) -> bool {
    if matches!(u, "–" | "rad") {
        return true;
    }
    ["", "k", "M", "G", "m", "µ", "n"].iter().any(|p| {
        ["m", "N", "s", "Hz", "Pa", "g", "m/s", "N/m"]
            .iter()
            .any(|b| u == format!("{p}{b}"))
    })
}

fn is_number(t: &str) -> bool {
    let t = t.strip_prefix('-').unwrap_or(t);
    let (m, e) = t.split_once('e').unwrap_or((t, "0"));
    !m.is_empty()
        && m.chars().all(|c| c.is_ascii_digit() || c == '.')
        && e.strip_prefix('-')
            .unwrap_or(e)
            .chars()
            .all(|c| c.is_ascii_digit())
}

/// What a reader would object to in one SVG (empty: nothing).
fn problems(svg: &str) -> Vec<String> {
    let elems = parse(svg);
    let mut out = Vec::new();
    let legends: Vec<(usize, Rect)> = elems
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e {
            Elem::Legend(r) => Some((i, *r)),
            _ => None,
        })
        .collect();
    for &(k, r) in &legends {
        for e in &elems[..k] {
            match e {
                Elem::Circle(c) if r.contains(*c) => {
                    out.push(format!("a marker at {c:?} under the legend {r:?}"));
                }
                Elem::Path { points, closed } => {
                    if let Some(p) = points.iter().find(|p| r.contains(**p)) {
                        out.push(format!("a vertex {p:?} under the legend {r:?}"));
                    } else if points.windows(2).any(|w| r.crossed_by(w[0], w[1])) {
                        out.push(format!("a line through the legend {r:?}"));
                    } else if *closed
                        && inside_polygon((0.5 * (r.x0 + r.x1), 0.5 * (r.y0 + r.y1)), points)
                    {
                        out.push(format!("a band under the legend {r:?}"));
                    }
                }
                _ => {}
            }
        }
    }
    let title_size = elems
        .iter()
        .filter_map(|e| match e {
            Elem::Text { size, .. } => Some(*size),
            _ => None,
        })
        .fold(0.0, f64::max);
    let (mut titles, mut labels) = (0, 0);
    for e in &elems {
        let Elem::Text { at, size, text } = e else {
            continue;
        };
        if *size >= title_size {
            titles += 1;
            continue;
        }
        if text.is_empty() || is_number(text) || legends.iter().any(|(_, r)| r.contains(*at)) {
            continue;
        }
        labels += 1;
        let unit = text
            .strip_suffix(')')
            .and_then(|t| t.rsplit_once('('))
            .or_else(|| text.strip_suffix(']').and_then(|t| t.rsplit_once('[')))
            .map(|(_, u)| u);
        if !unit.is_some_and(is_unit) {
            out.push(format!("axis label without a unit: {text:?}"));
        }
    }
    if labels < 2 * titles {
        out.push(format!("{titles} titles but {labels} axis labels"));
    }
    out
}

/// The legend entries of an SVG (the texts inside legend boxes).
fn legend_texts(svg: &str) -> Vec<String> {
    let elems = parse(svg);
    let boxes: Vec<Rect> = elems
        .iter()
        .filter_map(|e| match e {
            Elem::Legend(r) => Some(*r),
            _ => None,
        })
        .collect();
    elems
        .iter()
        .filter_map(|e| match e {
            Elem::Text { at, text, .. } if boxes.iter().any(|r| r.contains(*at)) => {
                Some(text.clone())
            }
            _ => None,
        })
        .collect()
}

fn svgs_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(svgs_under(&p));
        } else if p.extension().is_some_and(|x| x == "svg") {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn check_all(dir: &Path) -> Vec<String> {
    svgs_under(dir)
        .iter()
        .flat_map(|p| {
            let text = std::fs::read_to_string(p).unwrap();
            problems(&text)
                .into_iter()
                .map(move |m| format!("{}: {m}", p.display()))
        })
        .collect()
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn every_figure_keeps_its_legend_off_the_data_and_its_axes_in_units() {
    let tmp = tempfile::tempdir().unwrap();
    let d = |name: &str| tmp.path().join(name).to_string_lossy().into_owned();
    let t0 = std::time::Instant::now();
    // Runs: no pull-off and no gap (impacts), pull-off and gaps (the paper's protocol).
    djkr(&[
        "run",
        "scenarios/impacts.toml",
        "--plot",
        "--out",
        &d("impacts"),
    ]);
    djkr(&[
        "run",
        "scenarios/paper-protocol-300hz.toml",
        "--plot",
        "--out",
        &d("paper"),
    ]);
    // Sweeps: amplification, its map and the phase figure, with 4 and with 18 points.
    djkr(&[
        "sweep",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=10um,20um",
        "--set",
        "base.frequency=200,300",
        "--ensemble",
        "3",
        "--seed",
        "1",
        "--out",
        &d("sweep4"),
    ]);
    djkr(&[
        "sweep",
        "tests/sweep/tiny.toml",
        "--set",
        "base.amplitude=10um:60um:6",
        "--set",
        "base.frequency=200,300,400",
        "--ensemble",
        "2",
        "--seed",
        "1",
        "--out",
        &d("sweep18"),
    ]);
    djkr(&[
        "resonance",
        "scenarios/resonance-400hz.toml",
        "--freq",
        "380:420:5",
        "--out",
        &d("resonance"),
    ]);
    djkr(&[
        "continue",
        "scenarios/resonance-400hz.toml",
        "--param",
        "base.frequency",
        "--range",
        "340:600",
        "--fold-param",
        "base.amplitude",
        "--fold-range",
        "3um:0.5um",
        "--out",
        &d("continue"),
    ]);
    djkr(&[
        "shortcut-map",
        "scenarios/resonance-400hz.toml",
        "--freq",
        "300:400:2",
        "--amp",
        "0.1um:0.5um:2",
        "--out",
        &d("map"),
    ]);
    djkr(&[
        "accuracy",
        "scenarios/quasi-static-jkr.toml",
        "--methods",
        "implicit",
        "--tolerances",
        "1e-4,1e-6",
        "--repeats",
        "1",
        "--ref-rtol",
        "1e-10",
        "--out",
        &d("accuracy"),
    ]);
    djkr(&[
        "accuracy",
        "--imposed-area",
        "--nodes",
        "11,21,31",
        "--repeats",
        "1",
        "--out",
        &d("imposed-area"),
    ]);
    let data = tmp.path().join("data.csv");
    std::fs::write(
        &data,
        "base.frequency [Hz],base.amplitude [um],pull_off_amplification [1]\n\
         200,10,1.9\n300,20,3.5\n400,30,5.1\n",
    )
    .unwrap();
    djkr(&[
        "fit",
        data.to_str().unwrap(),
        "--scenario",
        "tests/sweep/tiny.toml",
        "--free",
        "adhesion.v0",
        "--out",
        &d("fit"),
    ]);
    djkr(&[
        "predict",
        "--fit",
        &d("fit"),
        "--set",
        "base.frequency=200:400:5",
        "--set",
        "base.amplitude=10um,30um",
        "--out",
        &d("predict"),
    ]);
    // design needs a fit with sigma for every key: the cheap rig's fit of two keys.
    let cheap = tmp.path().join("cheap");
    std::fs::create_dir_all(&cheap).unwrap();
    let cheap_fit = crate::design::cheap_fit(&cheap);
    djkr(&[
        "design",
        "--fit",
        cheap_fit.to_str().unwrap(),
        "--candidates",
        "base.amplitude=0um:20um:5",
        "stage[3].speed=30um/s:3000um/s:5log",
        "--add",
        "6",
        "--out",
        &d("design"),
    ]);
    djkr(&["figures", "--out", &d("figures")]);
    djkr(&["beta-fit", "--out", &d("beta-fit")]);
    eprintln!("figures made in {:.1} s", t0.elapsed().as_secs_f64());

    let expected = [
        "impacts/run.svg",
        "paper/run.svg",
        "sweep4/amplification.svg",
        "sweep4/amplification-map.svg",
        "sweep4/phase.svg",
        "sweep18/phase.svg",
        "resonance/resonance.svg",
        "resonance/resonance-phase.svg",
        "continue/branch.svg",
        "continue/fold_curves.svg",
        "map/shortcut-map-force.svg",
        "map/shortcut-map-delta.svg",
        "accuracy/work_precision.svg",
        "accuracy/work_precision_pull_off.svg",
        "imposed-area/quadrature.svg",
        "imposed-area/closed_form_map.svg",
        "fit/fit.svg",
        "predict/prediction.svg",
        "design/design.svg",
        "figures/fig2.svg",
        "figures/fig3a.svg",
        "figures/fig3b.svg",
        "figures/fig4.svg",
        "figures/fig8.svg",
        "beta-fit/beta_error_curve.svg",
    ];
    for f in expected {
        assert!(tmp.path().join(f).is_file(), "{f} was not written");
    }
    let bad = check_all(tmp.path());
    assert!(bad.is_empty(), "{}", bad.join("\n"));

    // The run of the paper's protocol marks its pull-off and its detachment, each named; the
    // impacts run, which never pulled off, names no pull-off anywhere.
    let paper = legend_texts(&read(&tmp.path().join("paper/run.svg")));
    for name in ["pull-off: most tensile ⟨F⟩", "detachment"] {
        assert!(paper.iter().any(|t| t == name), "{name}: {paper:?}");
    }
    let impacts = read(&tmp.path().join("impacts/run.svg"));
    assert!(
        !impacts.contains("pull-off"),
        "impacts/run.svg names a pull-off"
    );
    // 18 points of an ensemble: 18 legend entries; fold curves in µm, not metres.
    let phase = legend_texts(&read(&tmp.path().join("sweep18/phase.svg")));
    assert_eq!(phase.len(), 18, "{phase:?}");
    let folds = read(&tmp.path().join("continue/fold_curves.svg"));
    assert!(
        folds.contains("base.amplitude (µm)"),
        "fold curves not in µm"
    );
}

/// The checks against a folder of SVGs made elsewhere (`DJKR_SVG_DIR`), e.g. by an older build.
#[test]
#[ignore = "needs DJKR_SVG_DIR"]
fn check_a_folder() {
    let dir = std::env::var("DJKR_SVG_DIR").expect("DJKR_SVG_DIR");
    let bad = check_all(Path::new(&dir));
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn the_checks_see_a_legend_on_data_and_a_label_without_unit() {
    let svg = r##"<svg>
<text x="500" y="20" font-size="26">title</text>
<circle cx="50" cy="50" r="4"/>
<polyline points="10,90 90,90"/>
<rect x="40" y="40" width="30" height="30" opacity="0.88" fill="#FFFFFF"/>
<text x="45" y="55" font-size="16">entry</text>
<text x="300" y="690" font-size="20">time t (s)</text>
<text x="10" y="300" font-size="20">pull-off amplification</text>
<text x="10" y="300" font-size="17">-1.5e-3</text>
</svg>"##;
    let p = problems(svg);
    assert!(
        p.iter().any(|m| m.contains("marker at (50.0, 50.0)")),
        "{p:?}"
    );
    assert!(
        p.iter()
            .any(|m| m.contains("without a unit: \"pull-off amplification\"")),
        "{p:?}"
    );
    assert_eq!(p.len(), 2, "{p:?}");
    // A line crossing the box with no vertex inside it, and a band around it.
    let svg = r##"<svg><polyline points="0,55 100,55"/><polygon points="0,0 200,0 200,200 0,200"/>
<rect x="40" y="40" width="30" height="30" opacity="0.88" fill="#FFFFFF"/></svg>"##;
    let p = problems(svg);
    assert!(p.iter().any(|m| m.contains("line through")), "{p:?}");
    assert!(p.iter().any(|m| m.contains("band under")), "{p:?}");
}
