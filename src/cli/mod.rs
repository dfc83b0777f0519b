//! The `ssl` command line: one file per subcommand, the arguments in [`args`] (their
//! value parsers in `values`), the output destination in `sink`. The library knows
//! nothing of flags; the hints that name them are added here.

mod analyze;
pub mod args;
mod batch;
mod check;
mod evaluate;
mod geometry;
mod inputs;
mod outdir;
mod plot;
mod results;
mod simulate;
mod sink;
mod temporaries;
pub(crate) mod values;

use crate::localize::ErrorKind;
use crate::method::ParamsError;
use crate::stream::Warning;
use crate::{AnalysisError, OutputError};
use args::{Cli, Command};
use clap::Parser;

/// Runs the command line and returns the process exit status: 0 success, 1 a data
/// error (bad or failed input), 2 a usage error.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = e.exit_code();
            let _ = e.print();
            return code;
        }
    };
    sink::remove_temporaries_on_signal();
    // `ssl check`: 1 is a misfit, so a file it cannot read is 2.
    if let Command::Check(args) = &cli.command {
        return match check::run(args) {
            Ok(true) => 0,
            Ok(false) => 1,
            Err(e) if is_broken_pipe(&e) => 0,
            Err(e) => {
                error(&one_line(&e));
                2
            }
        };
    }
    let result = match cli.command {
        Command::Analyze(args) => rayon::ThreadPoolBuilder::new()
            .num_threads(args.threads as usize)
            .build()
            .map_err(anyhow::Error::from)
            .and_then(|pool| {
                pool.install(|| match &args.out_dir {
                    Some(dir) => batch::run(&args, dir),
                    None => analyze::run(&args),
                })
            }),
        Command::Geometry(args) => geometry::run(&args).map(|()| true),
        Command::Check(_) => unreachable!("handled above"),
        Command::Simulate(args) => simulate::run(&args).map(|()| true),
        Command::Evaluate(args) => evaluate::run(&args),
        Command::Plot(args) => plot::run(&args).map(|()| true),
        Command::Completions(args) => completions(args.shell).map(|()| true),
    };
    match result {
        Ok(true) => 0,
        Ok(false) => 1,
        Err(e) if is_broken_pipe(&e) => 0,
        Err(e) => {
            error(&one_line(&e));
            1
        }
    }
}

/// Prints the completion script for `shell`. clap_complete panics when its writer
/// fails, so the script is made in memory and written here, where a failure (a full
/// disk, a closed output) is an error line like any other.
fn completions(shell: clap_complete::Shell) -> anyhow::Result<()> {
    let mut cmd = <Cli as clap::CommandFactory>::command();
    let mut script = Vec::new();
    clap_complete::generate(shell, &mut cmd, "ssl", &mut script);
    print(&script)
}

/// Writes `text` to standard output; a failure names it (`cannot write standard output:
/// No space left on device`), and a reader that went away ends the run quietly.
fn print(text: &[u8]) -> anyhow::Result<()> {
    use std::io::Write;
    if sink::stdout_was_closed() {
        anyhow::bail!("cannot write standard output: it is closed (>&-)");
    }
    let mut out = std::io::stdout().lock();
    out.write_all(text)
        .and_then(|()| out.flush())
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::BrokenPipe => BrokenPipe.into(),
            _ => anyhow::anyhow!(
                "cannot write standard output: {}",
                crate::stream::io_reason(&e)
            ),
        })
}

/// An error chain as one line.
fn one_line(e: &anyhow::Error) -> String {
    format!("{e:#}").replace('\n', " ")
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<BrokenPipe>()
            || c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// The reader of standard output went away: the run ends quietly.
#[derive(Debug, thiserror::Error)]
#[error("the reader of the output went away")]
struct BrokenPipe;

/// An output failure as one line naming the destination (`cannot write out.csv: No space
/// left on device`); a closed pipe ends the run quietly.
fn output_error(shown: &str, e: OutputError) -> anyhow::Error {
    if e.is_broken_pipe() {
        return BrokenPipe.into();
    }
    anyhow::anyhow!("cannot write {shown}: {}", e.reason())
}

fn error(msg: &str) {
    eprintln!("ssl: error: {msg}");
}

fn warn(quiet: bool, msg: &str) {
    if !quiet {
        eprintln!("ssl: warning: {msg}");
    }
}

/// A recording's error as the command line reports it: the library's message, and what
/// to change on the command line when a flag would fix it.
fn with_hint(e: &AnalysisError) -> String {
    let hint = match &e.kind {
        ErrorKind::TooShort { .. } => "; use a smaller --frame-size".to_string(),
        ErrorKind::Params(ParamsError::FrameTooShort { needed, .. }) => {
            format!(": use --frame-size {needed} or more")
        }
        _ => String::new(),
    };
    format!("{e}{hint}")
}

/// A warning as the command line reports it.
fn warning_with_hint(name: &str, w: &Warning) -> String {
    let hint = match w {
        Warning::SearchBudget { .. } => " (--tolerance, --peaks)",
        Warning::FewDetections { steady: true, .. } => {
            "; --no-weighting localizes such steady sources"
        }
        Warning::FewDetections {
            threshold_per_pair: None,
            ..
        } => "; --min-score sets a fixed threshold per pair instead",
        Warning::FewDetections { .. } => "; --min-score sets the threshold per pair",
        _ => "",
    };
    format!("{name}: {w}{hint}")
}
