use super::*;
use crate::latency::Summary;
use crate::synthetic::{
    lidar_compute_ns, mapper_compute_ns, synthetic_run, trajectory_latency_ns, write_synthetic,
};
use crate::writer::{RecordWriter, WriterOptions};
use std::io::Cursor;

/// Budgets that the synthetic run's end to end (5..11 ms) misses above 9 ms.
const BUDGETS: &str = "[stage]\nsimulator = 1.0\nlidar = 1.5\nmapper = 5.0\n\
    teb_controller = 20.0\nglobal_planner = 200.0\nsupervisor = 5.0\n\
    [end_to_end]\ntick_to_command = 9.0\n";

fn file_of(bytes: Vec<u8>) -> RecordFile {
    RecordFile::from_bytes(Path::new("p.mcap"), bytes).unwrap()
}

/// The synthetic run with `budgets` attached.
fn synthetic_with_budgets(ticks: u64, budgets: &str) -> RecordFile {
    let mut w = RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default()).unwrap();
    w.attach(
        BUDGETS_ATTACHMENT,
        "application/toml",
        budgets.as_bytes(),
        0,
    )
    .unwrap();
    for s in synthetic_run(ticks) {
        w.write_raw(s.service, s.log_time, s.bytes.bytes()).unwrap();
    }
    file_of(w.finish().unwrap().0.into_inner())
}

fn row<'a>(r: &'a ProfileReport, name: &str) -> &'a Summary {
    r.table.stages.iter().find(|s| s.stage == name).unwrap()
}

#[test]
fn synthetic_run_figures_match_what_was_generated_scored_by_the_attached_budgets() {
    let r = profile_file(
        &synthetic_with_budgets(100, BUDGETS),
        &ProfileOptions::default(),
    )
    .unwrap();
    assert_eq!(r.budget_source, BudgetSource::Attached);
    let values: Vec<u64> = (0..100).map(lidar_compute_ns).collect();
    assert_eq!(
        *row(&r, "lidar"),
        Summary::of("lidar", &values, Some(1.5)).unwrap()
    );
    assert_eq!(row(&r, "lidar").max_ms, 1.9);
    // Idle acknowledgements are not compute samples.
    assert_eq!(row(&r, "teb_controller").samples, 20);
    assert_eq!(row(&r, "mapper").max_ms, mapper_compute_ns(4) as f64 / 1e6);
    let e2e = row(&r, "end_to_end");
    let expected: Vec<u64> = (0..100).step_by(5).map(trajectory_latency_ns).collect();
    assert_eq!(e2e.samples, 20);
    assert_eq!(e2e.max_ms, *expected.iter().max().unwrap() as f64 / 1e6);
    // Latencies of 10 and 11 ms exceed the 9 ms budget.
    assert_eq!(
        e2e.misses,
        expected.iter().filter(|&&v| v > 9_000_000).count()
    );
    assert_eq!(row(&r, "latency aisle/map/local").budget_ms, None);
    // Lockstep: the tick count only, never scored.
    let rel = r.table.tick_release.as_ref().unwrap();
    assert_eq!((rel.ticks, rel.mode.as_str()), (100, "lockstep"));
    assert!(rel.lateness.is_none());
    let table = r.table();
    assert!(table.contains("the record's budgets.toml"), "{table}");
    assert!(table.contains("not applicable"), "{table}");
    assert!(r.histograms().contains('#'));
    let back: LatencyTable = serde_json::from_str(&r.json()).unwrap();
    assert_eq!(back, r.table);
}

#[test]
fn given_budgets_override_and_a_record_without_any_is_not_scored() {
    let bytes = write_synthetic(Cursor::new(Vec::new()), 50, WriterOptions::default())
        .unwrap()
        .into_inner();
    let file = file_of(bytes);
    let r = profile_file(&file, &ProfileOptions::default()).unwrap();
    assert_eq!(r.budget_source, BudgetSource::None);
    assert!(r.table.stages.iter().all(|s| s.budget_ms.is_none()));
    assert!(r.table().contains("nothing is scored"));
    let given: Budgets = aisle_config::parse(Path::new("b.toml"), BUDGETS).unwrap();
    let opts = ProfileOptions {
        budgets: Some(given),
    };
    let r = profile_file(&file, &opts).unwrap();
    assert_eq!(r.budget_source, BudgetSource::Given);
    assert_eq!(row(&r, "lidar").budget_ms, Some(1.5));
}

#[test]
fn a_broken_attached_budgets_file_is_named() {
    let file = synthetic_with_budgets(10, "[stage]\nlidar = -1.0\n");
    let e = profile_file(&file, &ProfileOptions::default()).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("p.mcap (attachment budgets.toml)"), "{text}");
}

#[test]
fn every_sample_is_exported() {
    let r = profile_file(
        &synthetic_with_budgets(20, BUDGETS),
        &ProfileOptions::default(),
    )
    .unwrap();
    let mut csv = Vec::new();
    r.book.write_csv(&mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    let total: usize = r.table.stages.iter().map(|s| s.samples).sum();
    assert_eq!(csv.lines().count(), 1 + total);
    assert!(csv.contains("\nlidar,3,1.300000,\n"), "{csv}");
}

#[test]
fn a_file_without_latency_data_is_an_error() {
    let mut w = RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default()).unwrap();
    w.write_metadata("x", Default::default()).unwrap();
    let file = RecordFile::from_bytes(Path::new("empty.mcap"), w.finish().unwrap().0.into_inner())
        .unwrap();
    let e = profile_file(&file, &ProfileOptions::default()).unwrap_err();
    assert!(e.to_string().contains("empty.mcap"), "{e}");
}

#[test]
fn a_damaged_or_unfinished_record_is_noted_once() {
    let bytes = write_synthetic(Cursor::new(Vec::new()), 50, WriterOptions::default())
        .unwrap()
        .into_inner();
    // Cut in its summary: every message reads, but the recording was not finished.
    let r = profile_file(
        &file_of(bytes[..bytes.len() - 100].to_vec()),
        &ProfileOptions::default(),
    )
    .unwrap();
    let t = r.table();
    assert!(
        r.truncated
            .as_deref()
            .is_some_and(|t| t.contains("no summary"))
    );
    assert_eq!(t.matches("no summary").count(), 1, "{t}");
    assert_eq!(t.matches("note:").count(), 1, "{t}");
    // Cut in its data: one note.
    let r = profile_file(
        &file_of(bytes[..bytes.len() * 2 / 3].to_vec()),
        &ProfileOptions::default(),
    )
    .unwrap();
    let t = r.table();
    assert!(r.truncated.is_some());
    assert_eq!(t.matches("note:").count(), 1, "{t}");
    // A finished record: none.
    let r = profile_file(&file_of(bytes), &ProfileOptions::default()).unwrap();
    assert!(
        r.truncated.is_none() && !r.table().contains("note:"),
        "{}",
        r.table()
    );
}
