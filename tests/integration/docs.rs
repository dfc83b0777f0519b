//! The pages that say what is name files that exist: every `src/`, `benches/` or
//! `tests/` path in README.md and docs/ (not docs/experiments.md, whose dated entries
//! name the files of their day).

use std::path::Path;

#[test]
fn the_docs_name_files_that_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut pages = vec![root.join("README.md")];
    for entry in std::fs::read_dir(root.join("docs")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".md") && name != "experiments.md" {
            pages.push(path);
        }
    }
    let mut missing = Vec::new();
    let mut named = 0;
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        for (at, _) in text.match_indices(['`', ' ', '(']) {
            let rest = &text[at + 1..];
            if !["src/", "benches/", "tests/"]
                .iter()
                .any(|p| rest.starts_with(p))
            {
                continue;
            }
            let end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || "_/.-".contains(c)))
                .unwrap_or(rest.len());
            let path = rest[..end].trim_end_matches('.');
            named += 1;
            if !root.join(path).exists() {
                missing.push(format!("{}: {path}", page.display()));
            }
        }
    }
    assert!(named > 20, "only {named} paths found: the scan is broken");
    assert!(
        missing.is_empty(),
        "named but missing:\n{}",
        missing.join("\n")
    );
}
