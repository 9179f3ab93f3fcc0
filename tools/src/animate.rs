//! A recorded run as one self-contained HTML page that plays it back: the top view of
//! [`crate::render`] without the moving parts as the background (an embedded PNG: title,
//! axes, map, static scene, references, legend with the legs' names, scale bar), and over
//! it, tick by tick, the robot's footprint, the movable bodies where ground truth had
//! them at that time (a carried rack moves with the robot; a dropped one appears at its
//! destination only once set down), the driven trail coloured by mission leg and the
//! controller's newest band. Play, pause, speed and a time slider; the page fits the
//! window, opens at the time its URL names (`run.html#t=20`) and keeps that hash up to
//! date while it plays or seeks. No network, no script library.
//!
//! Reads the raw channels of the file; knows the message layouts, not the processes.

use crate::reader::RecordFile;
use crate::render::run::{BodyKind, MovableBody};
use crate::render::{LEG_COLORS, Layers, RenderError, RenderOptions, render_layers, write_output};
use aisle_messages::topics::names as s;
use aisle_messages::{ControllerBand, MAX_COMMANDS, MissionStatus, RobotState};
use std::fmt::Write as _;
use std::path::Path;

/// Footprint drawn for the robot (the Jackal's, as in `config/robot.toml`).
const ROBOT_LENGTH: f64 = 0.508;
const ROBOT_WIDTH: f64 = 0.43;

/// One tick of the playback.
#[derive(Debug, Clone, PartialEq, Default)]
struct Frame {
    tick: u64,
    t: f64,
    pose: [f64; 3],
    segment: u32,
    /// Index into the band list of the newest band at this tick.
    band: Option<usize>,
}

#[derive(Default)]
struct Playback {
    frames: Vec<Frame>,
    bands: Vec<Vec<[f64; 2]>>,
    truncated: Option<String>,
}

/// What the page holds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AnimationSummary {
    pub frames: usize,
    pub bands: usize,
    pub bytes: usize,
    pub truncated: Option<String>,
}

fn collect(file: &RecordFile) -> Playback {
    let mut pb = Playback::default();
    let mut segment = 0;
    let mut band = None;
    let truncated = file.for_each_payload(|topic, buf| match topic {
        s::MISSION_STATUS => {
            if let Some(st) = buf.view::<MissionStatus>() {
                segment = st.segment;
            }
        }
        s::CONTROLLER_BAND => {
            if let Some(b) = buf.view::<ControllerBand>() {
                let n = (b.len as usize).min(MAX_COMMANDS);
                let pts: Vec<[f64; 2]> = b.poses[..n]
                    .iter()
                    .filter(|p| p.x.is_finite() && p.y.is_finite())
                    .map(|p| [p.x, p.y])
                    .collect();
                band = (!pts.is_empty()).then(|| {
                    pb.bands.push(pts);
                    pb.bands.len() - 1
                });
            }
        }
        s::ROBOT_STATE => {
            if let Some(r) = buf.view::<RobotState>()
                && [r.pose.x, r.pose.y, r.pose.theta]
                    .iter()
                    .all(|v| v.is_finite() && v.abs() < 1e5)
            {
                pb.frames.push(Frame {
                    tick: r.header.tick,
                    t: r.header.stamp_ns as f64 * 1e-9,
                    pose: [r.pose.x, r.pose.y, r.pose.theta],
                    segment,
                    band,
                });
            }
        }
        _ => {}
    });
    pb.truncated = truncated;
    pb
}

/// Standard base64 (RFC 4648) with padding.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Numbers for the page, rounded to a millimetre (or a milliradian).
fn num(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    if r == 0.0 { "0".into() } else { format!("{r}") }
}

/// Writes `items` separated by commas, each with `item`.
fn json_list<T>(
    j: &mut String,
    items: impl IntoIterator<Item = T>,
    mut item: impl FnMut(&mut String, T),
) {
    for (i, x) in items.into_iter().enumerate() {
        if i > 0 {
            j.push(',');
        }
        item(j, x);
    }
}

/// The page's data: frames `[t, x, y, theta, leg, band]`, bands (flat x, y lists), the
/// movable bodies (`k` 1 for a rack, size, poses `[t, x, y, theta]` from that time on),
/// the legs' names and colours, the robot's size.
fn data_json(pb: &Playback, bodies: &[MovableBody], legs: &[String]) -> String {
    let mut j = String::from("{\"frames\":[");
    json_list(&mut j, &pb.frames, |j, f| {
        let _ = write!(
            j,
            "[{},{},{},{},{},{}]",
            num(f.t),
            num(f.pose[0]),
            num(f.pose[1]),
            num(f.pose[2]),
            f.segment,
            f.band.map_or(-1, |b| b as i64),
        );
    });
    j.push_str("],\"bands\":[");
    json_list(&mut j, &pb.bands, |j, b| {
        j.push('[');
        json_list(j, b, |j, p| {
            let _ = write!(j, "{},{}", num(p[0]), num(p[1]));
        });
        j.push(']');
    });
    j.push_str("],\"bodies\":[");
    json_list(&mut j, bodies, |j, b| {
        let rack = u8::from(b.kind == BodyKind::Rack);
        let _ = write!(
            j,
            "{{\"k\":{rack},\"l\":{},\"w\":{},\"p\":[",
            num(b.length),
            num(b.width)
        );
        json_list(j, &b.poses, |j, p| {
            let _ = write!(
                j,
                "[{},{},{},{}]",
                num(p.t),
                num(p.x),
                num(p.y),
                num(p.theta)
            );
        });
        j.push_str("]}");
    });
    j.push_str("],\"legs\":[");
    // serde_json quotes and escapes the names; a string cannot fail to serialise.
    json_list(&mut j, legs, |j, n| {
        j.push_str(&serde_json::to_string(n).unwrap_or_default());
    });
    j.push_str("],\"colors\":[");
    json_list(&mut j, &LEG_COLORS, |j, c| {
        let _ = write!(j, "\"rgb({},{},{})\"", c[0], c[1], c[2]);
    });
    let _ = write!(
        j,
        "],\"robot\":[{},{}]}}",
        num(ROBOT_LENGTH),
        num(ROBOT_WIDTH)
    );
    // Inside a <script>, "</" would end it early.
    j.replace("</", "<\\/")
}

const PAGE: &str = include_str!("animate_page.html");

/// Writes the playback page of a recorded file.
pub fn animate(
    path: &Path,
    out_html: &Path,
    opts: &RenderOptions,
) -> Result<AnimationSummary, RenderError> {
    let file = RecordFile::open(path)?;
    let background = Layers {
        driven: false,
        bands: false,
        movables: false,
    };
    let (picture, summary, run) = render_layers(&file, opts, background)?;
    let png = picture.png()?;
    let pb = collect(&file);
    let t = picture.transform;
    let transform = format!("[{},{},{},{},{},{}]", t[0], t[1], t[2], t[3], t[4], t[5]);
    let title: String = summary
        .title
        .lines()
        .next()
        .unwrap_or_default()
        .chars()
        .filter(|c| !"<>&\"'".contains(*c))
        .collect();
    let html = PAGE
        .replace("__TITLE__", &title)
        .replace("__TRANSFORM__", &transform)
        .replace("__DATA__", &data_json(&pb, &run.movables, &run.legs))
        .replace("__PNG__", &base64(&png));
    write_output(out_html, html.as_bytes())?;
    Ok(AnimationSummary {
        frames: pb.frames.len(),
        bands: pb.bands.len(),
        bytes: html.len(),
        truncated: pb.truncated,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::write_synthetic;
    use crate::writer::WriterOptions;
    use std::io::Cursor;

    #[test]
    fn base64_matches_the_rfc_vectors() {
        for (plain, encoded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), encoded);
        }
    }

    #[test]
    fn every_tick_becomes_a_frame_with_its_band() {
        let bytes = write_synthetic(Cursor::new(Vec::new()), 30, WriterOptions::default())
            .unwrap()
            .into_inner();
        let file = RecordFile::from_bytes(Path::new("run.mcap"), bytes).unwrap();
        let pb = collect(&file);
        assert_eq!(pb.frames.len(), 30);
        // Ticks in order, 0.1 s apart; the second half drives along y (segment 1).
        for w in pb.frames.windows(2) {
            assert!((w[1].t - w[0].t - 0.1).abs() < 1e-9);
        }
        assert_eq!(pb.frames.last().unwrap().segment, 1);
        // A band every 5th tick; a frame shows the newest band published before it.
        assert_eq!(pb.bands.len(), 6);
        assert!(pb.frames[0].band.is_none());
        assert_eq!(pb.frames[6].band, Some(1));
        let legs = ["out".to_string(), "back".to_string()];
        let j = data_json(&pb, &[], &legs);
        assert!(
            j.starts_with("{\"frames\":[[0,0,0,0,0,-1],"),
            "{}",
            &j[..60]
        );
        assert!(j.contains("\"legs\":[\"out\",\"back\"]"));
        assert!(j.ends_with("\"robot\":[0.508,0.43]}"));
    }

    /// The page's `poseAt`: a body's newest pose at or before `t`, its first before that.
    fn pose_at(body: &serde_json::Value, t: f64) -> Vec<f64> {
        let poses = body["p"].as_array().unwrap();
        let at = |p: &serde_json::Value| -> Vec<f64> {
            p.as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let mut pose = at(&poses[0]);
        for p in poses.iter().map(at) {
            if p[0] > t {
                break;
            }
            pose = p;
        }
        pose
    }

    #[test]
    fn the_page_moves_a_carried_rack_with_the_robot_and_drops_it_at_its_destination() {
        let file = crate::render::tests::carry_file();
        let background = Layers {
            driven: false,
            bands: false,
            movables: false,
        };
        let opts = RenderOptions::default();
        let (_, summary, run) = render_layers(&file, &opts, background).unwrap();
        // The background holds no movable body and no driven path: the page draws them.
        assert!(
            !summary
                .legend
                .iter()
                .any(|l| l.starts_with("moved") || l == "start")
        );
        assert!(summary.legend.contains(&"2: turn in place".to_string()));
        let j = data_json(&collect(&file), &run.movables, &run.legs);
        let d: serde_json::Value = serde_json::from_str(&j).unwrap();
        let rack = &d["bodies"][0];
        assert_eq!(
            (rack["k"].as_u64(), rack["l"].as_f64()),
            (Some(1), Some(0.88))
        );
        assert_eq!(d["bodies"][1]["k"].as_u64(), Some(0), "the unseen stack");
        // At the pick before it is carried, with the robot while carried (drives down
        // x = 2 from t = 3 s), at the drop from t = 5 s on.
        assert_eq!(pose_at(rack, 2.5)[1..3], [2.0, 0.0]);
        assert_eq!(pose_at(rack, 4.0)[1..3], [2.0, -1.0]);
        assert_eq!(pose_at(rack, 4.95)[1..3], [2.0, -1.9]);
        assert_eq!(pose_at(rack, 5.5)[1..3], [2.0, -2.0]);
        assert_eq!(d["legs"][2], "carry to drop");
    }
}
