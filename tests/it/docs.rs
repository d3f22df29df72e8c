//! Every figure the README quotes comes from a file a command wrote. Measured numbers sit in
//! blocks marked `<!-- quote FILE -->` … `<!-- end quote -->`, and each such block must appear
//! line for line, in order and unbroken, in FILE (a report under `docs/` that a bench wrote,
//! whose first lines name the command and the machine). Regenerate a report with the command
//! in its first line, then `scripts/quote-docs.py` copies the changed lines into the README;
//! this test says which block no longer matches.

use crate::common;

/// (file named by the marker, the block's lines, the README line where it starts).
fn quotes(readme: &str) -> Vec<(String, Vec<String>, usize)> {
    let mut out = Vec::new();
    let mut open: Option<(String, Vec<String>, usize)> = None;
    for (i, line) in readme.lines().enumerate() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix("<!-- quote ") {
            assert!(open.is_none(), "README.md:{}: quote inside a quote", i + 1);
            let file = rest.trim_end_matches("-->").trim().to_string();
            open = Some((file, Vec::new(), i + 1));
        } else if t == "<!-- end quote -->" {
            let q = open
                .take()
                .unwrap_or_else(|| panic!("README.md:{}: end without a quote", i + 1));
            out.push(q);
        } else if let Some(q) = &mut open {
            q.1.push(line.trim_end().to_string());
        }
    }
    assert!(open.is_none(), "README.md: a quote is never closed");
    out
}

#[test]
fn readme_quotes_match_the_reports() {
    let root = common::root();
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let qs = quotes(&readme);
    assert!(
        qs.len() >= 6,
        "expected the README's measured tables to be quoted, found {} quotes",
        qs.len()
    );
    for (file, lines, at) in &qs {
        let text = std::fs::read_to_string(root.join(file))
            .unwrap_or_else(|e| panic!("README.md:{at}: quotes {file}, which cannot be read: {e}"));
        assert!(
            text.lines().take(4).any(|l| l.starts_with("Written by `")),
            "{file} does not say which command and machine wrote it"
        );
        let body: Vec<&str> = lines
            .iter()
            .map(|l| l.as_str())
            .filter(|l| !l.is_empty())
            .collect();
        assert!(!body.is_empty(), "README.md:{at}: empty quote of {file}");
        let source: Vec<&str> = text
            .lines()
            .map(|l| l.trim_end())
            .filter(|l| !l.is_empty())
            .collect();
        let found = source
            .windows(body.len())
            .any(|w| w.iter().zip(&body).all(|(a, b)| a == b));
        assert!(
            found,
            "README.md:{at}: the quoted block is not in {file} as written (regenerated? run \
             scripts/quote-docs.py):\n{}",
            body.join("\n")
        );
    }
}

#[test]
fn quote_markers_are_parsed() {
    let q = quotes("a\n<!-- quote docs/x.md -->\n| 1 |\n\n| 2 |\n<!-- end quote -->\nb\n");
    assert_eq!(q.len(), 1);
    assert_eq!(q[0].0, "docs/x.md");
    assert_eq!(q[0].1, vec!["| 1 |", "", "| 2 |"]);
    assert_eq!(q[0].2, 2);
}
