use super::run::{BodyKind, Run, collect};
use super::*;
use crate::aligned::{message_bytes, zeroed_box};
use crate::synthetic::write_synthetic;
use crate::writer::{RecordWriter, WriterOptions};
use aisle_messages::topics::names as s;
use aisle_messages::{Message, MissionState, MissionStatus, RobotState, WorldTruth, write_name};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::io::Cursor;

fn synthetic_file(ticks: u64) -> RecordFile {
    let bytes = write_synthetic(Cursor::new(Vec::new()), ticks, WriterOptions::default())
        .unwrap()
        .into_inner();
    RecordFile::from_bytes(Path::new("r.mcap"), bytes).unwrap()
}

const SCENE: &str = r#"
[[body]]
name = "wall"
kind = "wall"
static = true
pose = [1.0, -3.0, 0.0]
size = [8.0, 0.2, 3.0]

[[body]]
name = "rack_a"
kind = "pallet_rack"
static = false
pose = [2.0, 0.0, 0.0]
size = [0.88, 0.8, 1.0]

[[body]]
name = "stack_1"
kind = "eur_pallet"
static = false
pose = [1.0, 2.0, 0.0]
size = [1.2, 0.8, 0.9]
"#;

/// The robot's pose, leg and mission state at tick `k` of the carry run: leg 0 "to pick"
/// drives along x to (2, 0) under the rack, leg 1 "turn in place" turns there by 162°,
/// leg 2 "carry to drop" drives back along y carrying the rack and sets it down at
/// (2, -2) at tick 50; then the mission has succeeded.
fn carry_pose(k: u64) -> ([f64; 3], u32, MissionState) {
    let f = k as f64;
    match k {
        0..20 => ([f * 0.1, 0.0, 0.0], 0, MissionState::Driving),
        20..30 => ([2.0, 0.0, (f - 20.0) * 0.1 * PI], 1, MissionState::Rotating),
        30..50 => ([2.0, -(f - 30.0) * 0.1, PI], 2, MissionState::Driving),
        _ => ([2.0, -2.0, PI], 2, MissionState::Succeeded),
    }
}

// Messages arrive boxed because the large ones would overflow the stack.
#[allow(clippy::boxed_local)]
fn push<M: Message>(w: &mut RecordWriter<Cursor<Vec<u8>>>, service: &str, mut m: Box<M>, k: u64) {
    m.header_mut().stamp_ns = k * 100_000_000;
    m.header_mut().tick = k;
    let written: u64 = w.counts().raw.values().sum();
    let log_time = 1_000_000_000 + k * 100_000_000 + written;
    w.write_raw(service, log_time, message_bytes(&*m)).unwrap();
}

/// A record of the carry run (see [`carry_pose`]) with its scene and seed.
pub(crate) fn carry_file() -> RecordFile {
    let mut w = RecordWriter::new(Cursor::new(Vec::new()), WriterOptions::default()).unwrap();
    w.attach("warehouse.toml", "application/toml", SCENE.as_bytes(), 0)
        .unwrap();
    w.write_metadata("aisle", BTreeMap::from([("seed".into(), "7".into())]))
        .unwrap();
    let names = ["to pick", "turn in place", "carry to drop"];
    for k in 0..60 {
        let (pose, leg, state) = carry_pose(k);
        let mut st = zeroed_box::<MissionStatus>();
        st.segment = leg;
        st.segments = 3;
        st.state = state as u32;
        st.distance = 4.0;
        write_name(&mut st.text, names[leg as usize]);
        push(&mut w, s::MISSION_STATUS, st, k);
        let mut r = zeroed_box::<RobotState>();
        [r.pose.x, r.pose.y, r.pose.theta] = pose;
        push(&mut w, s::ROBOT_STATE, r, k);
        let mut t = zeroed_box::<WorldTruth>();
        // As the simulator lists them: the bodies that can move (the wall is static: it
        // comes from the record's scene).
        t.len = 2;
        let carried = (30..50).contains(&k);
        let rack = if carried || k >= 50 {
            pose
        } else {
            [2.0, 0.0, 0.0]
        };
        let bodies = [
            ("rack_a", 1, rack, [0.88, 0.8, 1.0], u8::from(carried)),
            ("stack_1", 2, [1.0, 2.0, 0.0], [1.2, 0.8, 0.9], 0),
        ];
        for (b, (name, index, p, size, carried)) in t.bodies.iter_mut().zip(bodies) {
            write_name(&mut b.name, name);
            b.index = index;
            [b.pose.x, b.pose.y, b.pose.theta] = p;
            b.size = size;
            b.carried = carried;
        }
        push(&mut w, s::WORLD_TRUTH, t, k);
    }
    let bytes = w.finish().unwrap().0.into_inner();
    RecordFile::from_bytes(Path::new("carry.mcap"), bytes).unwrap()
}

fn carry_run() -> Run {
    collect(&carry_file(), &RenderOptions::default())
}

#[test]
fn the_legend_names_the_missions_legs_the_bodies_and_the_markers() {
    let (_, summary) = render_file(&carry_file(), &RenderOptions::default()).unwrap();
    assert_eq!(summary.legs, ["to pick", "turn in place", "carry to drop"]);
    let legend = &summary.legend;
    assert!(legend.contains(&"1: to pick".to_string()), "{legend:?}");
    assert!(
        legend.contains(&"3: carry to drop".to_string()),
        "{legend:?}"
    );
    // The turn in place is marked with how far it turned (0.9 pi by the last tick of it).
    assert!(
        legend.contains(&"2: turn in place (+162° in place)".to_string()),
        "{legend:?}"
    );
    for label in [
        "pallet racks",
        "unseen pallets/boxes",
        "start",
        "end, t = 5.9 s",
    ] {
        assert!(legend.contains(&label.to_string()), "{label}: {legend:?}");
    }
    assert!(
        !legend
            .iter()
            .any(|l| l.contains("SEGMENT") || l.contains("RACKS"))
    );
    assert_eq!(
        summary.title,
        "carry.mcap  ·  seed 7  ·  succeeded\n\
         mission: to pick → turn in place → carry to drop  ·  4.0 m driven in 5.9 s"
    );
}

#[test]
fn a_carried_rack_moves_with_the_robot_and_stays_where_it_was_set_down() {
    let run = carry_run();
    let kinds: Vec<(&str, BodyKind)> = run
        .movables
        .iter()
        .map(|b| (b.name.as_str(), b.kind))
        .collect();
    assert_eq!(
        kinds,
        [("rack_a", BodyKind::Rack), ("stack_1", BodyKind::Unseen)]
    );
    let rack = &run.movables[0];
    let before = rack.pose_at(2.5).unwrap();
    assert_eq!((before.x, before.y, before.carried), (2.0, 0.0, false));
    let carried = rack.pose_at(4.0).unwrap();
    assert!(
        carried.carried && (carried.y + 1.0).abs() < 1e-9,
        "{carried:?}"
    );
    let after = rack.pose_at(5.5).unwrap();
    assert_eq!((after.x, after.y, after.carried), (2.0, -2.0, false));
    assert_eq!(rack.dropped_at(), Some(5.0));
    assert!(!run.movables[1].moved());
    // The turn in place: one, in leg 1, counter-clockwise.
    assert_eq!(run.turns.len(), 1);
    let t = run.turns[0];
    // It starts from the pose before the first "rotating" status (leg 0's last).
    assert_eq!((t.leg, t.y, t.from), (1, 0.0, 0.0));
    assert!((t.x - 1.9).abs() < 1e-9, "{t:?}");
    assert!((t.to - 0.9 * PI).abs() < 1e-9, "{t:?}");
}

#[test]
fn the_picture_shows_the_legs_and_bodies_where_they_are() {
    let (p, _) = render_file(&carry_file(), &RenderOptions::default()).unwrap();
    // Leg 0's path along y = 0 in leg 0's colour.
    let (px, py) = p.to_px(1.0, 0.0);
    assert_eq!(p.get(px as u32, py as u32), Some(LEG_COLORS[0]));
    // Leg 2's path along x = 2 below the turn.
    let (px, py) = p.to_px(2.0, -1.0);
    assert_eq!(p.get(px as u32, py as u32), Some(LEG_COLORS[2]));
    // The unseen stack is tinted purple; the map's extent is the bodies' plus 2 m.
    let (px, py) = p.to_px(1.0, 2.0);
    let [r, g, b] = p.get(px as u32, py as u32).unwrap();
    assert!(b > g + 30 && r > g, "{r} {g} {b}");
    let (x0, y0) = p.to_px(-2.0, -5.0);
    assert!(x0 > 50.0 && y0 > 100.0 && (x0 as u32) < p.width && (y0 as u32) < p.height);
}

#[test]
fn renders_the_map_extent_at_the_requested_scale() {
    let file = synthetic_file(60);
    let opts = RenderOptions {
        pixels_per_metre: 20.0,
        band_every: 2,
        driven: true,
    };
    let (p, summary) = render_file(&file, &opts).unwrap();
    // The synthetic map is 40 x 60 cells of 0.5 m: 20 x 30 m, at 20 px a metre.
    assert!((p.transform[4] - 20.0).abs() < 0.1, "{:?}", p.transform);
    assert!((p.transform[5] + 20.0).abs() < 0.1, "{:?}", p.transform);
    assert_eq!((p.transform[2], p.transform[3]), (-5.0, -10.0));
    assert_eq!(summary.detected_cells, 2);
    assert_eq!(summary.reference_paths, 2);
    assert_eq!(summary.driven_poses, 60);
    assert!(summary.bands >= 5);
    assert!(
        summary
            .legend
            .contains(&"detected by the lidar".to_string())
    );
    // The static row 12 (y = -10 + 6.25 m) is dark; a detected cell is red.
    let (px, py) = p.to_px(0.0, -3.75);
    assert_eq!(
        p.get(px as u32, py as u32),
        Some([70, 70, 70]),
        "static map"
    );
    let (px, py) = p.to_px(-5.0 + 17.0 * 0.5 + 0.25, -10.0 + 24.0 * 0.5 + 0.25);
    let [r, g, b] = p.get(px as u32, py as u32).unwrap();
    assert!(r > 150 && g < 120 && b < 120, "{r} {g} {b}");
    let png = p.png().unwrap();
    let reader = png::Decoder::new(Cursor::new(png)).read_info().unwrap();
    assert_eq!(
        (reader.info().width, reader.info().height),
        (p.width, p.height)
    );
}

#[test]
fn rendering_is_deterministic_and_refuses_bad_scales() {
    let file = synthetic_file(20);
    let a = render_file(&file, &RenderOptions::default()).unwrap().0;
    let b = render_file(&file, &RenderOptions::default()).unwrap().0;
    assert_eq!(a.rgb, b.rgb);
    for bad in [0.0, -1.0, f64::NAN] {
        let opts = RenderOptions {
            pixels_per_metre: bad,
            band_every: 1,
            ..RenderOptions::default()
        };
        assert!(matches!(
            render_file(&file, &opts),
            Err(RenderError::InvalidScale(_))
        ));
    }
    let huge = RenderOptions {
        pixels_per_metre: 1000.0,
        ..RenderOptions::default()
    };
    assert!(matches!(
        render_file(&file, &huge),
        Err(RenderError::BadSize { .. })
    ));
}

#[test]
fn the_svg_is_the_same_picture_in_vectors() {
    let (svg, summary) = render_svg(&carry_file(), &RenderOptions::default()).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains(&format!("width=\"{}\"", summary.width)));
    for text in [
        "1: to pick",
        "unseen pallets/boxes",
        "rack_a, set down at 5.0 s",
        "x (m)",
    ] {
        assert!(svg.contains(text), "{text}");
    }
}

#[test]
fn an_output_other_than_png_svg_or_html_is_refused_before_the_record_is_read() {
    use std::path::Path;
    for ok in ["a.png", "b.SVG", "c.Html"] {
        assert!(OutputFormat::of(Path::new(ok)).is_ok(), "{ok}");
    }
    // The record does not exist: the extension is refused first, naming it.
    let e = render(
        Path::new("/nonexistent/run.mcap"),
        Path::new("/tmp/x.jpg"),
        &RenderOptions::default(),
    )
    .unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, RenderError::UnsupportedOutput { .. }), "{text}");
    assert!(text.contains("x.jpg") && text.contains(".jpg"), "{text}");
    assert!(text.contains(".png") && text.contains(".html"), "{text}");
    let e = OutputFormat::of(Path::new("noext"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("without an extension") && e.contains(".png"),
        "{e}"
    );
}
