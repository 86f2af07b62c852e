//! Docs that run (issue 27): the shell blocks of `README.md` and `docs/guide/*.md` run as written,
//! and every repository path the docs and the doc comments cite exists.
//!
//! Conventions (`docs/guide/docs-as-code.md`): a ```` ```sh ```` block is run with `sh -e` in a
//! fresh temporary folder per file (the repository's `scenarios/`, `tests/`, `docs/`,
//! `examples/`, `benches/` and `python/` linked beside it, the built `djkr` first on `PATH`) and
//! must exit 0; a ```` ```text output ```` block right after a run block lists lines that its
//! output (stdout and stderr) must contain, `...` matching any text; a block that cannot run is
//! fenced ```` ```sh no-run ```` with `<!-- no-run: why -->` on the line above; a block fenced
//! with `file=PATH` (```` ```toml file=tests/scenarios/good/minimal.toml ````) must equal that
//! repository file. The README's
//! ```` ```python ```` blocks run with the Python test venv when it imports `djkr` (made by
//! `tests/cli/python.rs` under `DJKR_TEST_INSTALL=1`), and are otherwise skipped with one line.

use crate::tools;

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One fenced block of a Markdown file.
#[derive(Debug)]
struct Block {
    /// First word of the info string (`sh`, `text`, `python`, ...).
    lang: String,
    /// The rest of the info string (`no-run`, `output`).
    attrs: Vec<String>,
    /// The block's text.
    body: String,
    /// 1-based line of the opening fence.
    line: usize,
    /// The last non-blank line before the fence (for the `<!-- no-run: ... -->` reason).
    before: String,
}

/// The fenced blocks of `text`, in order.
fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut lines = text.lines().enumerate();
    let mut before = String::new();
    while let Some((i, l)) = lines.next() {
        let t = l.trim_start();
        if let Some(info) = t.strip_prefix("```") {
            let mut words = info.split_whitespace();
            let lang = words.next().unwrap_or("").to_string();
            let attrs = words.map(str::to_string).collect();
            let mut body = String::new();
            for (_, l) in lines.by_ref() {
                if l.trim_start().starts_with("```") {
                    break;
                }
                body.push_str(l);
                body.push('\n');
            }
            out.push(Block {
                lang,
                attrs,
                body,
                line: i + 1,
                before: std::mem::take(&mut before),
            });
        } else if !t.is_empty() {
            before = t.to_string();
        }
    }
    out
}

/// True when `line` matches `pattern`, where `...` stands for any text (both trimmed).
fn matches(pattern: &str, line: &str) -> bool {
    let parts: Vec<&str> = pattern.trim().split("...").collect();
    let line = line.trim();
    let Some(rest) = line.strip_prefix(parts[0]) else {
        return false;
    };
    if parts.len() == 1 {
        return rest.is_empty();
    }
    let mut rest = rest;
    for (k, p) in parts[1..].iter().enumerate() {
        let last = k == parts.len() - 2;
        if last {
            return rest.ends_with(p) && rest.len() >= p.len();
        }
        match rest.find(p) {
            Some(at) => rest = &rest[at + p.len()..],
            None => return false,
        }
    }
    true
}

/// A fresh folder with the repository's input folders linked into it.
fn sandbox(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("docs-run-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("sandbox folder");
    for sub in [
        "scenarios",
        "tests",
        "docs",
        "examples",
        "benches",
        "python",
    ] {
        std::os::unix::fs::symlink(root().join(sub), dir.join(sub)).expect("symlink");
    }
    dir
}

/// `PATH` with the built `djkr`'s folder first.
fn path_with_djkr() -> std::ffi::OsString {
    let bin = Path::new(env!("CARGO_BIN_EXE_djkr"))
        .parent()
        .expect("binary folder")
        .to_path_buf();
    std::env::join_paths(std::iter::once(bin).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .expect("PATH")
}

/// The Python of the test venv when it imports djkr: built here under `DJKR_TEST_INSTALL=1` (as
/// tests/cli/python.rs builds it, so that a fresh CI runs the tour's Python block too), otherwise
/// only an existing one.
fn venv_python() -> Option<PathBuf> {
    if tools::may_install() {
        return match tools::djkr_python() {
            Ok(py) => Some(py),
            Err(why) => panic!("the Python blocks need the test venv: {why}"),
        };
    }
    let py = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("python-venv/bin/python");
    (py.exists() && tools::runs(&py, "import djkr")).then_some(py)
}

/// Run the runnable blocks of one Markdown file in order; return the problems found.
fn run_file(rel: &str, python: Option<&Path>) -> Vec<String> {
    let text = std::fs::read_to_string(root().join(rel)).expect("doc readable");
    let dir = sandbox(&rel.replace('/', "_"));
    let mut problems = Vec::new();
    // The output of the last block that ran (None: the last code block did not run).
    let mut last: Option<String> = None;
    let mut skipped_python = false;
    for b in blocks(&text) {
        let at = format!("{rel}:{}", b.line);
        let no_run = b.attrs.iter().any(|a| a == "no-run");
        let shell = matches!(b.lang.as_str(), "sh" | "bash" | "shell" | "console");
        if no_run {
            if !b.before.starts_with("<!-- no-run:") {
                problems.push(format!(
                    "{at}: a no-run block needs `<!-- no-run: why -->` on the line above"
                ));
            }
            last = None;
            continue;
        }
        if let Some(file) = b.attrs.iter().find_map(|a| a.strip_prefix("file=")) {
            // A block that shows a repository file must show it as it is.
            match std::fs::read_to_string(root().join(file)) {
                Ok(text) if text == b.body => {}
                Ok(_) => problems.push(format!(
                    "{at}: the block differs from `{file}`; copy the file into it"
                )),
                Err(e) => problems.push(format!("{at}: `{file}`: {e}")),
            }
            continue;
        }
        if b.lang == "text" && b.attrs.iter().any(|a| a == "output") {
            let Some(out) = &last else { continue };
            for want in b.body.lines().filter(|l| !l.trim().is_empty()) {
                if !out.lines().any(|l| matches(want, l)) {
                    problems.push(format!(
                        "{at}: no output line matches {want:?}; the output was:\n{out}"
                    ));
                }
            }
            continue;
        }
        let cmd = if shell {
            let mut c = Command::new("sh");
            c.arg("-e").arg("-c").arg(&b.body);
            c
        } else if b.lang == "python" && rel == "README.md" {
            let Some(py) = python else {
                skipped_python = true;
                last = None;
                continue;
            };
            let mut c = Command::new(py);
            c.arg("-c").arg(&b.body);
            c
        } else {
            last = None;
            continue;
        };
        let mut cmd = cmd;
        cmd.current_dir(&dir)
            .env("PATH", path_with_djkr())
            .env_remove("DJKR_BLESS");
        let out = cmd.output().expect("block runs");
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        if !out.status.success() {
            problems.push(format!(
                "{at}: block exited with {}:\n{}\n{text}",
                out.status, b.body
            ));
        }
        last = Some(text);
    }
    if skipped_python {
        tools::skipped(
            &format!("the Python blocks of {rel} (tests/cli/docs_run.rs)"),
            "no venv under target/tmp/python-venv that imports djkr (DJKR_TEST_INSTALL=1 makes it)",
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    problems
}

/// The Markdown files of the docs: README.md and everything under docs/.
fn markdown_files() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    walk(&root().join("docs"), "md", &mut out);
    out
}

fn walk(dir: &Path, ext: &str, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = rd.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            walk(&p, ext, out);
        } else if p.extension().is_some_and(|e| e == ext) {
            out.push(p);
        }
    }
}

#[test]
fn readme_tour_and_guide_blocks_run_as_written() {
    let python = venv_python();
    let mut files = vec!["README.md".to_string()];
    let mut guide = Vec::new();
    walk(&root().join("docs/guide"), "md", &mut guide);
    files.extend(guide.iter().map(|p| {
        p.strip_prefix(root())
            .expect("under root")
            .to_string_lossy()
            .into_owned()
    }));
    let mut problems = Vec::new();
    for f in &files {
        problems.extend(run_file(f, python.as_deref()));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}

/// Every shell block of the docs is either runnable or says why not; the README's tour has
/// runnable blocks with expected output (so the run test above checks something).
#[test]
fn every_shell_block_is_marked() {
    let mut problems = Vec::new();
    let mut files = vec![root().join("README.md")];
    walk(&root().join("docs/guide"), "md", &mut files);
    for f in files {
        let text = std::fs::read_to_string(&f).expect("readable");
        for b in blocks(&text) {
            let no_run = b.attrs.iter().any(|a| a == "no-run");
            if no_run && !b.before.starts_with("<!-- no-run:") {
                problems.push(format!(
                    "{}:{}: no-run block without `<!-- no-run: why -->` above it",
                    f.display(),
                    b.line
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let bs = blocks(&readme);
    let runnable = bs
        .iter()
        .filter(|b| b.lang == "sh" && b.attrs.is_empty())
        .count();
    let outputs = bs
        .iter()
        .filter(|b| b.lang == "text" && b.attrs.iter().any(|a| a == "output"))
        .count();
    assert!(
        runnable >= 5 && outputs >= 5,
        "README's tour: {runnable} runnable sh blocks, {outputs} output blocks"
    );
}

/// The README's test command is the one `.ci/run` runs, and README stays short.
#[test]
fn readme_test_command_is_what_ci_runs() {
    let ci = std::fs::read_to_string(root().join(".ci/run")).expect(".ci/run");
    let ci_tests: Vec<&str> = ci
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("cargo test"))
        .collect();
    assert_eq!(
        ci_tests.len(),
        1,
        ".ci/run runs one test command: {ci_tests:?}"
    );
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let in_readme = blocks(&readme)
        .iter()
        .filter(|b| b.lang == "sh")
        .any(|b| b.body.lines().any(|l| l.trim() == ci_tests[0]));
    assert!(
        in_readme,
        "README.md's \"Two commands\" must show `{}`, the test command .ci/run runs",
        ci_tests[0]
    );
    let lines = readme.lines().count();
    assert!(lines <= 250, "README.md has {lines} lines (at most 250)");
}

/// The folders whose paths the docs cite, from the repository root.
const PREFIXES: [&str; 9] = [
    "core/",
    "vendor/",
    "src/",
    "docs/",
    "scenarios/",
    "tests/",
    "examples/",
    "benches/",
    "python/",
];

/// The repository paths cited in `text`: tokens that start with one of [`PREFIXES`] at a word
/// boundary, with `{a,b}` expanded; globs, placeholders (`<scene>`, `…`, `...`) are left out.
fn cited_paths(text: &str) -> Vec<String> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let boundary = i == 0 || {
            let c = b[i - 1];
            !(c.is_ascii_alphanumeric() || matches!(c, b'/' | b'_' | b'-' | b'.' | b'$'))
        };
        let Some(p) = PREFIXES
            .iter()
            .find(|p| boundary && b[i..].starts_with(p.as_bytes()))
        else {
            i += 1;
            continue;
        };
        let start = i;
        let mut j = i + p.len();
        while j < b.len() {
            let c = b[j];
            if c == b'{' {
                match text[j..].find('}') {
                    Some(k) => j += k + 1,
                    None => break,
                }
            } else if c.is_ascii_alphanumeric()
                || matches!(c, b'_' | b'.' | b'/' | b'-' | b'*' | b'<' | b'>')
            {
                j += 1;
            } else {
                break;
            }
        }
        let tok = text[start..j].trim_end_matches(['.', ':']);
        i = j.max(i + 1);
        let placeholder = tok.contains(['*', '<', '>'])
            || tok.contains("...")
            || text[j..].starts_with('…')
            || text[j..].starts_with("...");
        if placeholder || tok == p.trim_end_matches('/') {
            continue;
        }
        out.extend(expand(tok));
    }
    out
}

/// `a{x,y}b` → `axb`, `ayb` (one level).
fn expand(tok: &str) -> Vec<String> {
    match (tok.find('{'), tok.find('}')) {
        (Some(a), Some(z)) if a < z => tok[a + 1..z]
            .split(',')
            .map(|m| format!("{}{m}{}", &tok[..a], &tok[z + 1..]))
            .collect(),
        _ => vec![tok.to_string()],
    }
}

/// The relative Markdown link targets of `text` (`](target)`), without anchors.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("](") {
        rest = &rest[at + 2..];
        let Some(end) = rest.find(')') else { break };
        let target = rest[..end].split('#').next().unwrap_or("").trim();
        let external = target.contains("://") || target.starts_with("mailto:");
        if !target.is_empty() && !external && !target.contains(' ') {
            out.push(target.to_string());
        }
    }
    out
}

/// The bare source file names cited in `text` (`` `model.rs` ``, `` `conftest.py` ``: in
/// backticks, no folder), each with the folder cited last before it in `text` (a repository
/// path ending in `/`), if any. The caller passes one paragraph or list item.
fn bare_names(text: &str) -> Vec<(String, Option<String>)> {
    let mut out = Vec::new();
    let mut folder: Option<String> = None;
    for (k, piece) in text.split('`').enumerate() {
        if k % 2 == 0 {
            continue;
        }
        if let Some(dir) = cited_paths(piece).into_iter().rfind(|p| p.ends_with('/')) {
            folder = Some(dir);
            continue;
        }
        let plain = !piece.is_empty()
            && piece
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if plain && (piece.ends_with(".rs") || piece.ends_with(".py")) && !piece.starts_with('.') {
            out.push((piece.to_string(), folder.clone()));
        }
    }
    out
}

/// Whether a tracked file named `name` exists under `folder` (any depth), or anywhere in the
/// repository without a folder.
fn bare_name_exists(files: &[PathBuf], name: &str, folder: Option<&str>) -> bool {
    files.iter().any(|f| {
        f.file_name().is_some_and(|n| n == name)
            && folder.is_none_or(|d| f.starts_with(root().join(d.trim_end_matches('/'))))
    })
}

/// The repository's source files (`.rs`, `.py`), for the bare-name check.
fn source_files() -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in [
        "src", "core", "python", "tests", "examples", "benches", "vendor",
    ] {
        walk(&root().join(dir), "rs", &mut files);
        walk(&root().join(dir), "py", &mut files);
    }
    files
}

/// The paragraphs and list items of Markdown `text`, with the 1-based line each starts on.
fn paragraphs(text: &str) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut open = false;
    for (n, line) in text.lines().enumerate() {
        let t = line.trim_start();
        let item = t.starts_with("- ") || t.starts_with("* ") || t.starts_with('|');
        if t.is_empty() {
            open = false;
            continue;
        }
        if !open || item {
            out.push((n + 1, String::new()));
            open = true;
        }
        let last = out.last_mut().expect("a paragraph");
        last.1.push_str(line);
        last.1.push('\n');
    }
    out
}

#[test]
fn every_cited_path_exists() {
    let root = root();
    let mut missing = Vec::new();
    let sources = source_files();
    // Markdown: cited repository paths and relative links.
    for f in markdown_files() {
        let text = std::fs::read_to_string(&f).expect("readable");
        let rel = f
            .strip_prefix(&root)
            .expect("under root")
            .display()
            .to_string();
        // A bare file name: under the folder cited before it in its paragraph, or anywhere.
        for (n, para) in paragraphs(&text) {
            for (name, folder) in bare_names(&para) {
                if !bare_name_exists(&sources, &name, folder.as_deref()) {
                    missing.push(format!(
                        "{rel}:{n}: cites `{name}`, which is in no {}",
                        folder.map_or("folder of the repository".into(), |d| format!("`{d}`"))
                    ));
                }
            }
        }
        for (n, line) in text.lines().enumerate() {
            for p in cited_paths(line) {
                if !root.join(&p).exists() {
                    missing.push(format!(
                        "{rel}:{}: cites `{p}`, which does not exist",
                        n + 1
                    ));
                }
            }
            for l in links(line) {
                let dir = f.parent().expect("file in a folder");
                if !dir.join(&l).exists() {
                    missing.push(format!(
                        "{rel}:{}: links to `{l}`, which does not exist",
                        n + 1
                    ));
                }
            }
        }
    }
    // Doc comments of the Rust sources (the root crate, and `core/` once it exists).
    let mut commented = Vec::new();
    for dir in ["src", "core/src", "python/src"] {
        walk(&root.join(dir), "rs", &mut commented);
    }
    for f in commented {
        let text = std::fs::read_to_string(&f).expect("readable");
        let rel = f
            .strip_prefix(&root)
            .expect("under root")
            .display()
            .to_string();
        for (n, line) in text.lines().enumerate() {
            let t = line.trim_start();
            if !(t.starts_with("//!") || t.starts_with("///")) {
                continue;
            }
            for p in cited_paths(t) {
                if !root.join(&p).exists() {
                    missing.push(format!(
                        "{rel}:{}: doc comment cites `{p}`, which does not exist",
                        n + 1
                    ));
                }
            }
            for (name, folder) in bare_names(t) {
                if !bare_name_exists(&sources, &name, folder.as_deref()) {
                    missing.push(format!(
                        "{rel}:{}: doc comment cites `{name}`, which is in no {}",
                        n + 1,
                        folder.map_or("folder of the repository".into(), |d| format!("`{d}`"))
                    ));
                }
            }
        }
    }
    assert!(
        missing.is_empty(),
        "{} cited path(s) missing (fix the text, or the path if the file moved):\n{}",
        missing.len(),
        missing.join("\n")
    );
}

/// A bare file name is looked up under the folder its paragraph cited before it.
#[test]
fn bare_names_are_read_with_their_folder() {
    assert_eq!(
        bare_names("- `core/src/steady/`: validate (`crosscheck.rs`); `report.rs` tables"),
        [
            (
                "crosscheck.rs".to_string(),
                Some("core/src/steady/".to_string())
            ),
            (
                "report.rs".to_string(),
                Some("core/src/steady/".to_string())
            )
        ]
    );
    assert_eq!(
        bare_names("`conftest.py`, `summary.json`, `x.rs y`"),
        [("conftest.py".to_string(), None)]
    );
    let files = source_files();
    assert!(bare_name_exists(
        &files,
        "crosscheck.rs",
        Some("core/src/steady/")
    ));
    assert!(!bare_name_exists(
        &files,
        "report.rs",
        Some("core/src/steady/")
    ));
    assert!(bare_name_exists(&files, "steady.rs", Some("src/")));
    assert!(!bare_name_exists(&files, "no-such-file.rs", None));
    let p = paragraphs("a\nb\n\n- c\n- d\n  e\n");
    assert_eq!(p.iter().map(|(n, _)| *n).collect::<Vec<_>>(), [1, 4, 5]);
}

#[test]
fn path_finder_reads_what_the_docs_write() {
    assert_eq!(
        cited_paths("see `src/dynamics/dp8.rs`, and src/jkr.rs."),
        ["src/dynamics/dp8.rs", "src/jkr.rs"]
    );
    assert_eq!(
        cited_paths("`scenarios/paper-protocol-{200,300}hz.toml`"),
        [
            "scenarios/paper-protocol-200hz.toml",
            "scenarios/paper-protocol-300hz.toml"
        ]
    );
    assert_eq!(
        cited_paths("core/src/jkr.rs, `core/src/steady/`"),
        ["core/src/jkr.rs", "core/src/steady/"]
    );
    assert!(cited_paths("docs/accuracy/<scene>/ src/… scenarios/*.toml").is_empty());
    assert!(matches(
        "  fold  x = 449.28... Hz...",
        "fold  x = 449.284138 Hz, |μ|"
    ));
    assert!(!matches("status ok", "status ok detached"));
    assert!(matches("a...", "abc"));
}

/// Every `cargo install` the docs show builds the versions of Cargo.lock (`--locked`): without
/// it cargo re-resolves the dependencies, rebuilds a binary the tests never checked and fails
/// offline (issue 33). The command reference's examples name `fit` too.
#[test]
fn docs_install_the_locked_binary_and_help_shows_fit() {
    let mut unlocked = Vec::new();
    for f in markdown_files() {
        let text = std::fs::read_to_string(&f).expect("readable");
        for (n, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(at) = rest.find("cargo install") {
                rest = &rest[at + "cargo install".len()..];
                let command: String = rest.chars().take_while(|c| *c != '`').collect();
                if !command.split_whitespace().any(|w| w == "--locked") {
                    unlocked.push(format!("{}:{}: {line}", f.display(), n + 1));
                }
            }
        }
    }
    assert!(
        unlocked.is_empty(),
        "cargo install without --locked:\n{}",
        unlocked.join("\n")
    );
    let help = Command::new(env!("CARGO_BIN_EXE_djkr"))
        .arg("help")
        .output()
        .expect("djkr help runs");
    let help = String::from_utf8_lossy(&help.stdout);
    let examples: Vec<&str> = help
        .lines()
        .skip_while(|l| l.trim() != "Examples:")
        .take_while(|l| !l.trim().is_empty())
        .collect();
    assert!(
        examples
            .iter()
            .any(|l| l.trim_start().starts_with("djkr fit ")),
        "{help}"
    );
}
