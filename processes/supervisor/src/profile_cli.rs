//! `aisle profile`: the command-line side of `aisle_tools::profile` (the latency table
//! of a recorded run, as `aisle run` prints it live).

use aisle_tools::latency::Budgets;
use aisle_tools::profile::{ProfileError, ProfileOptions, ProfileReport, profile_with};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Debug, Clone, clap::Args)]
pub struct ProfileArgs {
    /// The MCAP record (`aisle run --record`).
    pub file: PathBuf,
    /// Score against this budgets file instead of the `budgets.toml` attached to the
    /// record.
    #[arg(long)]
    pub budgets: Option<PathBuf>,
    /// Also write the table as JSON (the shape of `aisle run --report`'s `latency`
    /// and `tick_release`).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Also write every sample as CSV (stage, tick, ms).
    #[arg(long)]
    pub samples: Option<PathBuf>,
    /// Also write a latency plot (SVG).
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Print histograms too.
    #[arg(long)]
    pub histograms: bool,
}

pub fn profile(a: &ProfileArgs) -> ExitCode {
    let outputs = [
        ("--json", &a.json),
        ("--samples", &a.samples),
        ("--svg", &a.svg),
    ];
    let outputs: Vec<(&str, &std::path::Path)> = outputs
        .into_iter()
        .filter_map(|(flag, p)| Some((flag, p.as_deref()?)))
        .collect();
    let mut inputs = vec![("the record", a.file.as_path())];
    inputs.extend(a.budgets.as_deref().map(|b| ("--budgets", b)));
    if let Err(e) = crate::file_roles::distinct(&inputs, &outputs) {
        return crate::exit::fail(e);
    }
    // Before the record is read (a long one takes a while): an output it cannot write,
    // or one another command writes now (the locks are held until this one ends).
    let mut _locks = Vec::with_capacity(outputs.len());
    for (flag, p) in &outputs {
        match crate::file_roles::writable_output(flag, p) {
            Ok(l) => _locks.push(l),
            Err(e) => return crate::exit::fail(e),
        }
    }
    let budgets = match &a.budgets {
        Some(p) => match aisle_config::load::<Budgets>(p) {
            Ok(b) => Some(b),
            Err(e) => return crate::exit::fail(e),
        },
        None => None,
    };
    let report = match profile_with(&a.file, &ProfileOptions { budgets }) {
        Ok(r) => r,
        Err(e) => return crate::exit::fail(e),
    };
    print!("{}", report.table());
    if a.histograms {
        print!("{}", report.histograms());
    }
    let damaged = report.truncated.is_some();
    for (path, write) in [
        (a.json.as_deref(), ProfileReport::write_json as Writer),
        (a.samples.as_deref(), ProfileReport::write_samples as Writer),
        (a.svg.as_deref(), ProfileReport::write_svg as Writer),
    ] {
        let Some(path) = path else { continue };
        if let Err(e) = write(&report, path) {
            return crate::exit::fail(e);
        }
        println!("wrote {}", path.display());
    }
    if damaged {
        // Profiled, but of a damaged record: exit 2, as for every command.
        return crate::exit::could_not();
    }
    ExitCode::SUCCESS
}

/// One of the report's file outputs.
type Writer = fn(&ProfileReport, &std::path::Path) -> Result<(), ProfileError>;
