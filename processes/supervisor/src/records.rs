//! `aisle replay`, `aisle profile` and `aisle render`: the command-line side of the MCAP
//! tools in aisle-tools (which hold the formats and the algorithms).

use crate::cli::ReplayArgs;
use aisle_bus::Instance;
use std::path::Path;
use std::process::ExitCode;

fn fail(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(1)
}

pub fn replay(a: &ReplayArgs) -> ExitCode {
    let instance = match Instance::new(a.prefix.clone(), a.root.clone()) {
        Ok(i) => i,
        Err(e) => return fail(e),
    };
    if !(a.rate.is_finite() && a.rate > 0.0) {
        return fail(format!("--rate must be positive, got {}", a.rate));
    }
    if !(a.start.is_finite() && a.start >= 0.0) {
        return fail(format!("--start must be >= 0 seconds, got {}", a.start));
    }
    let mut opts = aisle_tools::replay::ReplayOptions::new(&a.file, instance);
    opts.rate = (!a.fast).then_some(a.rate);
    opts.topics = a.topics.clone();
    opts.start_offset_ns = (a.start * 1e9).round() as u64;
    match aisle_tools::replay::replay(&opts) {
        Ok(s) => {
            let total: u64 = s.published.values().sum();
            println!("replayed {total} messages from {}", a.file.display());
            for (service, n) in &s.published {
                println!("  {service:<28} {n}");
            }
            if let Some(t) = &s.truncated {
                println!("the file is damaged: replayed what could be read; {t}");
            }
            if s.stopped {
                println!("stopped early (interrupted)");
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}

pub fn profile(file: &Path, deadline_ms: f64, svg: Option<&Path>, histograms: bool) -> ExitCode {
    if !(deadline_ms.is_finite() && deadline_ms > 0.0) {
        return fail(format!("--deadline-ms must be positive, got {deadline_ms}"));
    }
    let opts = aisle_tools::profile::ProfileOptions {
        deadline_ns: (deadline_ms * 1e6) as u64,
    };
    let report = match aisle_tools::profile::profile_with(file, &opts) {
        Ok(r) => r,
        Err(e) => return fail(e),
    };
    print!("{}", report.table());
    if histograms {
        print!("{}", report.histograms());
    }
    if let Some(t) = &report.truncated {
        println!("the file is damaged: profiled what could be read; {t}");
    }
    if let Some(p) = svg {
        if let Err(e) = report.write_svg(p) {
            return fail(e);
        }
        println!("wrote {}", p.display());
    }
    ExitCode::SUCCESS
}

pub fn render(file: &Path, out: &Path, pixels_per_metre: f64, band_every: usize) -> ExitCode {
    if !(pixels_per_metre.is_finite() && (1.0..=200.0).contains(&pixels_per_metre)) {
        return fail(format!(
            "--pixels-per-metre must be within 1..=200, got {pixels_per_metre}"
        ));
    }
    let opts = aisle_tools::render::RenderOptions {
        pixels_per_metre,
        band_every,
    };
    match aisle_tools::render::render(file, out, &opts) {
        Ok(_) => {
            println!("wrote {}", out.display());
            ExitCode::SUCCESS
        }
        Err(e) => fail(e),
    }
}
