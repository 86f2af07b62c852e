//! `djkr::api::design` (issue 34), the call behind `djkr design` and Python's `djkr.design`,
//! through the library's typed request: on a fit of the bundled data
//! (`examples/data/pull-off-300hz.csv`) its report is the command's `--json` to the byte, its
//! files are the command's, and a typed σ out of range is refused as the text one is, before
//! the output folder is made.

use djkr::fit::{DesignRequest, FitFolder, Sigma, Target};
use djkr::sweep::Axis;
use std::path::Path;
use std::process::Command;

const CANDIDATES: [&str; 2] = [
    "base.amplitude=0um:20um:5",
    "stage[3].speed=30um/s:3000um/s:5log",
];

#[test]
fn the_library_call_is_the_commands_and_refuses_a_typed_sigma_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let fit = dir.path().join("fit");
    crate::fit::fit_cheap(
        &root.join("examples/data/pull-off-300hz.csv"),
        &fit,
        &["--free", "adhesion.v0", "--free", "adhesion.n"],
    );
    let cli = dir.path().join("cli");
    let o = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .args(["design", "--fit", fit.to_str().unwrap(), "--candidates"])
        .args(CANDIDATES)
        .args([
            "--add",
            "5",
            "--sigma",
            "3%",
            "--criterion",
            "adhesion.n",
            "--json",
        ])
        .args(["--out", cli.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let folder = FitFolder::read(&fit).unwrap();
    let axes: Vec<Axis> = CANDIDATES.iter().map(|a| Axis::parse(a).unwrap()).collect();
    let mut req = DesignRequest::new(axes, 5);
    req.sigma = Some(Sigma::Relative(0.03));
    req.criterion = Target::Key("adhesion.n".into());
    assert_eq!(Sigma::parse("3%", &folder).unwrap(), Sigma::Relative(0.03));
    assert_eq!(Target::parse("adhesion.n"), req.criterion);
    let lib = dir.path().join("lib");
    let report = djkr::api::design(&folder, &req, Some((lib.clone(), false)), None).unwrap();
    // The same text as --json prints (shortest round-trip digits: to the bit).
    let printed = String::from_utf8(o.stdout).unwrap();
    assert_eq!(
        serde_json::to_string_pretty(&report).unwrap(),
        printed.trim_end()
    );
    for name in ["design.csv", "design.json"] {
        assert_eq!(
            std::fs::read(lib.join(name)).unwrap(),
            std::fs::read(cli.join(name)).unwrap(),
            "{name}"
        );
    }
    // design.csv's columns, as Python gets them: its header, and the repeats summing to K.
    let csv = std::fs::read_to_string(cli.join("design.csv")).unwrap();
    let columns = report.columns();
    let names: Vec<&str> = columns.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names.join(","), csv.lines().next().unwrap());
    match &columns[6] {
        (name, djkr::fit::Column::Whole(r)) if name == "repeats [1]" => {
            assert_eq!(r.iter().sum::<u64>(), 5)
        }
        other => panic!("{other:?}"),
    }

    // A typed σ is held to the text's range, in the same words.
    let bad = dir.path().join("bad");
    for (sigma, words) in [
        (
            Sigma::Relative(0.0),
            "sigma = 0%: a relative sigma must be a percentage above 0 and at most 1000 %",
        ),
        (
            Sigma::Relative(20.0),
            "sigma = 2000%: a relative sigma must be a percentage above 0 and at most 1000 %",
        ),
        (Sigma::Relative(f64::NAN), "sigma = NaN%: a relative sigma"),
        (
            Sigma::Absolute(-1.0),
            "sigma = -1: must be a positive value in the unit of pull_off_amplification (1,",
        ),
        (
            Sigma::Absolute(f64::INFINITY),
            "sigma = inf: must be a positive value",
        ),
    ] {
        req.sigma = Some(sigma);
        let e = djkr::api::design(&folder, &req, Some((bad.clone(), false)), None).unwrap_err();
        assert!(e.is_input(), "{e}");
        assert!(e.to_string().starts_with(words), "{sigma:?}: {e}");
        assert!(!bad.exists(), "{sigma:?}: the output folder was made");
    }
    let e = Sigma::parse("0%", &folder).unwrap_err().to_string();
    assert!(e.starts_with("sigma = 0%: a relative sigma must be"), "{e}");
}

/// The opt-in study "design pays".
mod pays;
