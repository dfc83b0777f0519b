//! The man pages in man/ are generated from the clap definition; this test fails when
//! they are stale. Regenerate with: `SSL_UPDATE_MAN=1 cargo test --test man`.

#[path = "../src/cli/args.rs"]
#[allow(dead_code)]
mod args;

use clap::CommandFactory;
use std::path::Path;

fn render(cmd: clap::Command) -> String {
    let mut buf = Vec::new();
    clap_mangen::Man::new(cmd).render(&mut buf).unwrap();
    String::from_utf8(buf).unwrap()
}

fn pages() -> Vec<(String, String)> {
    let cmd = args::Cli::command();
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
            "man/{file} is stale: regenerate with `SSL_UPDATE_MAN=1 cargo test --test man`"
        );
    }
}
