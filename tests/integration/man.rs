//! The man pages in man/ are generated from the clap definition; this test fails when
//! they are stale. Regenerate with: `SSL_UPDATE_MAN=1 cargo test --test integration man::`.

use clap::CommandFactory;
use std::path::Path;

fn render(cmd: clap::Command) -> String {
    let mut buf = Vec::new();
    clap_mangen::Man::new(cmd.clone()).render(&mut buf).unwrap();
    let mut page = String::from_utf8(buf).unwrap();
    // clap_mangen writes a positional that takes several values as `<FILE>`; the
    // synopsis says `<FILE>...`, as `--help` does.
    for arg in cmd.get_positionals() {
        if arg.get_num_args().is_some_and(|n| n.max_values() > 1) {
            let name = arg.get_value_names().unwrap()[0].as_str();
            let single = format!("<\\fI{name}\\fR>");
            page = page.replacen(&single, &format!("{single}..."), 1);
        }
    }
    page
}

fn pages() -> Vec<(String, String)> {
    let cmd = ssl::cli::args::Cli::command();
    let mut pages = vec![("ssl.1".to_string(), render(cmd.clone()))];
    for sub in cmd.get_subcommands() {
        // clap takes 'static names; leaking two short strings in a test is harmless.
        let name: &'static str = Box::leak(format!("ssl-{}", sub.get_name()).into_boxed_str());
        let page = sub
            .clone()
            .name(name)
            .bin_name(format!("ssl {}", sub.get_name()))
            .version(env!("CARGO_PKG_VERSION"));
        pages.push((format!("{name}.1"), render(page)));
    }
    pages
}

#[test]
fn man_pages_match_the_command_line() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("man");
    let update = std::env::var_os("SSL_UPDATE_MAN").is_some();
    for (file, text) in pages() {
        let path = dir.join(&file);
        if update {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &text).unwrap();
            continue;
        }
        let current = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            current == text,
            "man/{file} is stale: regenerate with `SSL_UPDATE_MAN=1 cargo test --test integration man::`"
        );
    }
}

/// `ssl analyze`'s options as docs/guide.md lists them: one table per group of the help,
/// each flag with its default and the first paragraph of its help, from the same
/// definitions as `--help` and the man page.
fn option_tables() -> String {
    let mut cmd = ssl::cli::args::Cli::command();
    cmd.build();
    let analyze = cmd
        .get_subcommands()
        .find(|s| s.get_name() == "analyze")
        .expect("analyze");
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for arg in analyze.get_arguments() {
        let id = arg.get_id().as_str();
        if arg.is_positional() || id == "help" || id == "version" {
            continue;
        }
        let heading = arg
            .get_help_heading()
            .unwrap_or("Input and output")
            .to_string();
        let mut flag = String::new();
        if let Some(s) = arg.get_short() {
            flag.push_str(&format!("-{s}, "));
        }
        flag.push_str(&format!("--{}", arg.get_long().expect("a long flag")));
        let takes_value = arg.get_num_args().is_some_and(|n| n.takes_values());
        if takes_value {
            if let Some(names) = arg.get_value_names() {
                flag.push_str(&format!(" {}", names[0]));
            }
        }
        let default = if takes_value {
            let d: Vec<String> = arg
                .get_default_values()
                .iter()
                .map(|v| v.to_string_lossy().into_owned())
                .collect();
            d.join(", ")
        } else {
            String::new()
        };
        let mut help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
        let values: Vec<String> = arg
            .get_possible_values()
            .iter()
            .map(|v| format!("`{}`", v.get_name()))
            .collect();
        if !values.is_empty() && takes_value {
            help.push_str(&format!(" ({})", values.join(", ")));
        }
        let row = format!(
            "| `{flag}` | {} | {} |",
            if default.is_empty() {
                String::new()
            } else {
                format!("`{default}`")
            },
            help.replace('|', "\\|")
        );
        match groups.iter_mut().find(|(h, _)| *h == heading) {
            Some((_, rows)) => rows.push(row),
            None => groups.push((heading, vec![row])),
        }
    }
    let mut out = String::new();
    for (heading, rows) in groups {
        out.push_str(&format!(
            "\n#### {heading}\n\n| flag | default | meaning |\n|---|---|---|\n"
        ));
        for r in rows {
            out.push_str(&r);
            out.push('\n');
        }
    }
    out
}

/// The guide's option tables are generated: this test fails when they drift from the
/// definitions (regenerate with the man pages, `SSL_UPDATE_MAN=1`).
#[test]
fn the_guide_s_option_tables_match_the_command_line() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/guide.md");
    let guide = std::fs::read_to_string(&path).unwrap();
    let (begin, end) = (
        "<!-- options: generated from the flags by tests/integration/man.rs -->\n",
        "<!-- end of the generated options -->",
    );
    let start = guide.find(begin).expect("the guide's generated options") + begin.len();
    let stop = guide[start..].find(end).expect("their end") + start;
    let now = option_tables();
    if std::env::var_os("SSL_UPDATE_MAN").is_some() {
        let updated = format!("{}{now}\n{}", &guide[..start], &guide[stop..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    assert!(
        guide[start..stop].trim() == now.trim(),
        "docs/guide.md's option tables are stale: regenerate with `SSL_UPDATE_MAN=1 cargo test --test integration man::`"
    );
}

/// The help and the man pages state only what is true: every page they refer to exists,
/// `-V` works wherever it is listed, variadic arguments say so, the score is not said
/// to be at most 1 per pair, and `ssl analyze --help` has examples.
#[test]
fn help_and_man_pages_say_only_what_is_true() {
    let pages = pages();
    let names: Vec<&str> = pages
        .iter()
        .map(|(f, _)| f.trim_end_matches(".1"))
        .collect();
    for (file, text) in &pages {
        for (i, _) in text.match_indices("(1)") {
            let start = text[..i]
                .rfind(|c: char| c.is_whitespace())
                .map_or(0, |s| s + 1);
            let page = text[start..i].replace("\\-", "-");
            assert!(
                names.contains(&page.as_str()),
                "{file} refers to a missing {page}(1)"
            );
        }
        assert!(!text.contains("at most 1 per microphone pair"), "{file}");
    }
    let analyze = &pages.iter().find(|(f, _)| f == "ssl-analyze.1").unwrap().1;
    // clap_mangen shows an optional list without its dots; --help shows them (below).
    assert!(analyze.contains("[\\fIPATH\\fR]"), "the PATH argument");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ssl"))
        .args(["analyze", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    assert!(
        help.contains("Examples:") && help.contains("[PATH]..."),
        "{help}"
    );
    for sub in [
        "analyze",
        "geometry",
        "simulate",
        "evaluate",
        "plot",
        "completions",
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_ssl"))
            .args([sub, "-V"])
            .output()
            .unwrap();
        assert!(out.status.success(), "ssl {sub} -V");
    }
}

#[test]
fn completions_for_every_shell() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_ssl"))
            .args(["completions", shell])
            .output()
            .unwrap();
        assert!(out.status.success(), "{shell}");
        let script = String::from_utf8(out.stdout).unwrap();
        assert!(
            script.contains("analyze") && script.contains("min-score"),
            "{shell}"
        );
    }
}
