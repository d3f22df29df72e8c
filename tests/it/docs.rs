//! Every figure the README and the pages under `docs/` quote comes from a file a command wrote.
//! Measured numbers sit in blocks marked `<!-- quote FILE -->` … `<!-- end quote -->`, and each
//! such block must appear line for line, in order and unbroken, in FILE (a report under
//! `docs/` that a bench or script wrote, whose first lines name the command and the machine).
//! A quoted plain-text report may keep its code fence inside the block: fence lines are not
//! compared. Regenerate a report with the command in its first line, then
//! `scripts/quote-docs.py` copies the changed lines into every page; this test says which
//! block of which page no longer matches. A hand-written page may not carry a table of
//! measured figures outside such a block.

use crate::common;

use std::path::{Path, PathBuf};

/// (file named by the marker, the block's lines, the line where it starts), for the page
/// named `page` (only used in messages).
fn quotes(text: &str, page: &str) -> Vec<(String, Vec<String>, usize)> {
    let mut out = Vec::new();
    let mut open: Option<(String, Vec<String>, usize)> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix("<!-- quote ") {
            assert!(open.is_none(), "{page}:{}: quote inside a quote", i + 1);
            let file = rest.trim_end_matches("-->").trim().to_string();
            open = Some((file, Vec::new(), i + 1));
        } else if t == "<!-- end quote -->" {
            let q = open
                .take()
                .unwrap_or_else(|| panic!("{page}:{}: end without a quote", i + 1));
            out.push(q);
        } else if let Some(q) = &mut open {
            q.1.push(line.trim_end().to_string());
        }
    }
    if let Some((file, _, at)) = open {
        panic!("{page}:{at}: the quote of {file} is never closed");
    }
    out
}

/// The pages that may quote: the README and every Markdown file under `docs/`, sorted.
fn pages(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let mut out = vec![root.join("README.md")];
    walk(&root.join("docs"), &mut out);
    out
}

/// Whether a report's first lines name the command that wrote it (`Written by ...` in a
/// bench's Markdown or a script's text, `command: ...` in the fuzzer's summary).
fn names_its_command(report: &str) -> bool {
    report
        .lines()
        .take(4)
        .any(|l| l.contains("Written by ") || l.starts_with("command: "))
}

/// Checks one page's quotes against their reports; returns how many it holds.
fn check_page(root: &Path, page: &str, text: &str) -> usize {
    let qs = quotes(text, page);
    for (file, lines, at) in &qs {
        let report = std::fs::read_to_string(root.join(file))
            .unwrap_or_else(|e| panic!("{page}:{at}: quotes {file}, which cannot be read: {e}"));
        assert!(
            names_its_command(&report),
            "{page}:{at}: {file} does not say which command and machine wrote it"
        );
        let body: Vec<&str> = lines
            .iter()
            .map(|l| l.as_str())
            .filter(|l| !l.is_empty() && !l.trim_start().starts_with("```"))
            .collect();
        assert!(!body.is_empty(), "{page}:{at}: empty quote of {file}");
        let source: Vec<&str> = report
            .lines()
            .map(|l| l.trim_end())
            .filter(|l| !l.is_empty())
            .collect();
        let found = source
            .windows(body.len())
            .any(|w| w.iter().zip(&body).all(|(a, b)| a == b));
        assert!(
            found,
            "{page}:{at}: the quoted block is not in {file} as written (regenerated? run \
             scripts/quote-docs.py):\n{}",
            body.join("\n")
        );
    }
    qs.len()
}

#[test]
fn quotes_in_the_readme_and_docs_match_the_reports() {
    let root = common::root();
    let mut total = 0;
    let mut quoting = Vec::new();
    for path in pages(&root) {
        let page = path.strip_prefix(&root).unwrap().display().to_string();
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{page}: {e}"));
        let n = check_page(&root, &page, &text);
        if n > 0 {
            quoting.push(page);
        }
        total += n;
    }
    // The measured tables that the README used to carry now live in the kind and topic pages;
    // losing the markers (and with them the check) must fail here.
    assert!(
        total >= 30,
        "expected the docs' measured tables to be quoted, found {total} quotes in {quoting:?}"
    );
    // Each page below carries measured figures; without a quote they would go unchecked.
    for page in [
        "docs/kinds/anjyo.md",
        "docs/kinds/fur.md",
        "docs/kinds/wisps.md",
        "docs/kinds/strips.md",
        "docs/performance.md",
        "docs/viewer.md",
        "docs/testing.md",
        "docs/mesh_head.md",
        "docs/fuzzing.md",
    ] {
        assert!(
            quoting.iter().any(|p| p == page),
            "{page} quotes no report: its figures would go unchecked"
        );
    }
}

/// Whether a table cell reads as a measured figure: a decimal number, maybe with a unit
/// (`12.5`, `3.1x`, `0.2 %`, `74.1 ms`); whole numbers (counts, sizes, defaults) are not.
fn measured(cell: &str) -> bool {
    let c = cell.trim();
    let c = ["x", "%", "ms", "s"]
        .iter()
        .find_map(|u| c.strip_suffix(u))
        .unwrap_or(c)
        .trim()
        .replace(',', "");
    c.contains('.') && c.parse::<f64>().is_ok()
}

/// Rows of a page's tables, outside its quote blocks, that hold a measured figure:
/// (line, row).
fn typed_rows(text: &str) -> Vec<(usize, String)> {
    let mut inside = false;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with("<!-- quote ") {
            inside = true;
        } else if t == "<!-- end quote -->" {
            inside = false;
        } else if !inside && t.starts_with('|') && t.split('|').any(measured) {
            out.push((i + 1, t.to_string()));
        }
    }
    out
}

#[test]
fn hand_written_pages_type_no_measured_table() {
    let root = common::root();
    for path in pages(&root) {
        let page = path.strip_prefix(&root).unwrap().display().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        // A report a command wrote holds its own tables.
        if names_its_command(&text) {
            continue;
        }
        let rows = typed_rows(&text);
        assert!(
            rows.is_empty(),
            "{page}:{}: a table of measured figures typed by hand; quote it from the report \
             that holds it (<!-- quote FILE --> ... <!-- end quote -->):\n{}",
            rows[0].0,
            rows[0].1
        );
    }
}

#[test]
fn quote_markers_are_parsed() {
    let q = quotes(
        "a\n<!-- quote docs/x.md -->\n| 1 |\n\n| 2 |\n<!-- end quote -->\nb\n",
        "t.md",
    );
    assert_eq!(q.len(), 1);
    assert_eq!(q[0].0, "docs/x.md");
    assert_eq!(q[0].1, vec!["| 1 |", "", "| 2 |"]);
    assert_eq!(q[0].2, 2);
    let typed = "| a | ms |\n|---|---:|\n| ribbons | 410.1 |\n| count | 12 |\n";
    assert_eq!(
        typed_rows(typed),
        vec![(3, "| ribbons | 410.1 |".to_string())]
    );
    assert!(typed_rows(&format!("<!-- quote r.md -->\n{typed}<!-- end quote -->\n")).is_empty());
    assert!(measured(" 3.1x ") && measured("0.2 %") && measured("74.1 ms"));
    assert!(!measured("12") && !measured("`0.5`") && !measured("1,000"));
}

#[test]
fn a_changed_figure_is_caught() {
    let root = common::root();
    let dir = std::env::temp_dir().join(format!("kami-docs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("r.md"),
        "Written by `kami bench x` on a test.\n\n| a | b |\n|---|---|\n| 1 | 2.5 |\n",
    )
    .unwrap();
    let rel = dir.join("r.md");
    let good = format!(
        "<!-- quote {} -->\n| a | b |\n|---|---|\n| 1 | 2.5 |\n<!-- end quote -->\n",
        rel.display()
    );
    // `root.join` of an absolute path is that path, so the temporary report is read.
    assert_eq!(check_page(&root, "t.md", &good), 1);
    let fenced = good
        .replace("| a | b |", "```\n| a | b |")
        .replace("2.5 |\n", "2.5 |\n```\n");
    assert_eq!(check_page(&root, "t.md", &fenced), 1);
    let bad = good.replace("2.5", "2.6");
    let caught = std::panic::catch_unwind(|| check_page(&root, "t.md", &bad));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(caught.is_err(), "a figure that is not in its report passed");
}
