//! A recorded run as one self-contained HTML page that plays it back: the top view of
//! [`crate::render`] without the driven path as the background (an embedded PNG), and
//! over it, tick by tick, the robot's footprint, the movable bodies where ground truth
//! had them (a carried rack moves with the robot), the driven trail coloured by mission
//! segment and the controller's newest band. Play, pause, speed and a time slider; no
//! network, no script library.
//!
//! Reads the raw channels of the file; knows the message layouts, not the processes.

use crate::reader::RecordFile;
use crate::render::{RenderError, RenderOptions, SEGMENT_COLORS, render_file, write_output};
use aisle_messages::topics::names as s;
use aisle_messages::{
    ControllerBand, MAX_BODIES, MAX_COMMANDS, MissionStatus, RobotState, WorldTruth,
};
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
    /// Index into the body-pose list of the movable bodies at this tick.
    bodies: Option<usize>,
}

#[derive(Default)]
struct Playback {
    frames: Vec<Frame>,
    bands: Vec<Vec<[f64; 2]>>,
    /// Each entry: (x, y, theta, length, width) of every movable body.
    body_sets: Vec<Vec<[f64; 5]>>,
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
    let mut bodies: Option<usize> = None;
    let truncated = file.for_each_payload(|topic, buf| {
        match topic {
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
            s::WORLD_TRUTH => {
                if let Some(w) = buf.view::<WorldTruth>() {
                    let n = (w.len as usize).min(MAX_BODIES);
                    let set: Vec<[f64; 5]> = w.bodies[..n]
                        .iter()
                        .filter(|b| b.is_static == 0)
                        .map(|b| [b.pose.x, b.pose.y, b.pose.theta, b.size[0], b.size[1]])
                        .filter(|v| v.iter().all(|x| x.is_finite() && x.abs() < 1e5))
                        .collect();
                    if bodies.is_none_or(|i| pb.body_sets[i] != set) {
                        pb.body_sets.push(set);
                        bodies = Some(pb.body_sets.len() - 1);
                    }
                    // The simulator publishes a tick's state before its ground truth.
                    if let Some(f) = pb.frames.last_mut()
                        && f.tick == w.header.tick
                    {
                        f.bodies = bodies;
                    }
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
                        bodies,
                    });
                }
            }
            _ => {}
        }
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

fn data_json(pb: &Playback) -> String {
    let mut j = String::from("{\"frames\":[");
    json_list(&mut j, &pb.frames, |j, f| {
        let _ = write!(
            j,
            "[{},{},{},{},{},{},{}]",
            num(f.t),
            num(f.pose[0]),
            num(f.pose[1]),
            num(f.pose[2]),
            f.segment,
            f.band.map_or(-1, |b| b as i64),
            f.bodies.map_or(-1, |b| b as i64)
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
    json_list(&mut j, &pb.body_sets, |j, set| {
        j.push('[');
        json_list(j, set, |j, b| {
            let _ = write!(
                j,
                "[{},{},{},{},{}]",
                num(b[0]),
                num(b[1]),
                num(b[2]),
                num(b[3]),
                num(b[4])
            );
        });
        j.push(']');
    });
    j.push_str("],\"colors\":[");
    json_list(&mut j, &SEGMENT_COLORS, |j, c| {
        let _ = write!(j, "\"rgb({},{},{})\"", c[0], c[1], c[2]);
    });
    let _ = write!(
        j,
        "],\"robot\":[{},{}]}}",
        num(ROBOT_LENGTH),
        num(ROBOT_WIDTH)
    );
    j
}

const PAGE: &str = r##"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>aisle run: __TITLE__</title>
<style>body{font:14px sans-serif;margin:12px}canvas{border:1px solid #ccc;display:block}
#bar{margin:8px 0;display:flex;gap:8px;align-items:center}#t{width:60vw}</style></head>
<body><div id="bar"><button id="play">pause</button>
<select id="speed"><option>1</option><option selected>4</option><option>10</option></select>x
<input id="t" type="range" min="0" value="0"><span id="clock"></span></div>
<canvas id="view"></canvas>
<script>
const D=__DATA__;const T=__TRANSFORM__;
const img=new Image();img.src="data:image/png;base64,__PNG__";
const cv=document.getElementById("view"),cx=cv.getContext("2d");
const slider=document.getElementById("t"),clock=document.getElementById("clock");
const F=D.frames;slider.max=Math.max(F.length-1,0);
let k=0,playing=true,last=null;
function px(x,y){return [T[0]+x*T[2],T[1]-y*T[2]];}
function rect(x,y,th,l,w,fill,stroke){const c=Math.cos(th),s=Math.sin(th);cx.beginPath();
for(const [a,b] of [[l/2,w/2],[-l/2,w/2],[-l/2,-w/2],[l/2,-w/2]]){const p=px(x+a*c-b*s,y+a*s+b*c);cx.lineTo(p[0],p[1]);}
cx.closePath();if(fill){cx.fillStyle=fill;cx.fill();}if(stroke){cx.strokeStyle=stroke;cx.lineWidth=2;cx.stroke();}}
function draw(){cx.drawImage(img,0,0);if(!F.length)return;const f=F[k];
if(f[6]>=0)for(const b of D.bodies[f[6]])rect(b[0],b[1],b[2],b[3],b[4],"rgba(160,100,40,0.55)",null);
cx.lineWidth=3;for(let i=1;i<=k;i++){const a=px(F[i-1][1],F[i-1][2]),b=px(F[i][1],F[i][2]);
cx.strokeStyle=D.colors[F[i][4]%D.colors.length];cx.beginPath();cx.moveTo(a[0],a[1]);cx.lineTo(b[0],b[1]);cx.stroke();}
if(f[5]>=0){const b=D.bands[f[5]];cx.strokeStyle="rgb(40,170,60)";cx.fillStyle="rgb(40,170,60)";cx.lineWidth=1.5;cx.beginPath();
for(let i=0;i<b.length;i+=2){const p=px(b[i],b[i+1]);cx.lineTo(p[0],p[1]);}cx.stroke();
for(let i=0;i<b.length;i+=2){const p=px(b[i],b[i+1]);cx.beginPath();cx.arc(p[0],p[1],2,0,7);cx.fill();}}
rect(f[1],f[2],f[3],D.robot[0],D.robot[1],"rgba(20,20,20,0.8)","#000");
const h=px(f[1]+0.35*Math.cos(f[3]),f[2]+0.35*Math.sin(f[3])),o=px(f[1],f[2]);
cx.strokeStyle="#fff";cx.lineWidth=2;cx.beginPath();cx.moveTo(o[0],o[1]);cx.lineTo(h[0],h[1]);cx.stroke();
clock.textContent="t = "+f[0].toFixed(1)+" s  (segment "+(f[4]+1)+")";slider.value=k;}
function tick(now){if(playing&&F.length){if(last!==null){const dt=(now-last)/1000*Number(document.getElementById("speed").value);
const target=F[k][0]+dt;while(k<F.length-1&&F[k+1][0]<=target)k++;if(k>=F.length-1)playing=false;}last=now;}else last=null;
draw();document.getElementById("play").textContent=playing?"pause":"play";requestAnimationFrame(tick);}
document.getElementById("play").onclick=()=>{if(k>=F.length-1)k=0;playing=!playing;};
slider.oninput=()=>{k=Number(slider.value);playing=false;};
img.onload=()=>{cv.width=img.width;cv.height=img.height;requestAnimationFrame(tick);};
</script></body></html>
"##;

/// Writes the playback page of a recorded file.
pub fn animate(
    path: &Path,
    out_html: &Path,
    opts: &RenderOptions,
) -> Result<AnimationSummary, RenderError> {
    let file = RecordFile::open(path)?;
    let background = RenderOptions {
        band_every: 0,
        driven: false,
        ..*opts
    };
    let (canvas, _) = render_file(&file, &background)?;
    let png = canvas.png()?;
    let pb = collect(&file);
    let (ox, oy) = canvas.to_px(0.0, 0.0);
    let transform = format!("[{ox},{oy},{}]", opts.pixels_per_metre);
    let title: String = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
        .chars()
        .filter(|c| c.is_alphanumeric() || "._- ".contains(*c))
        .collect();
    let html = PAGE
        .replace("__TITLE__", &title)
        .replace("__TRANSFORM__", &transform)
        .replace("__DATA__", &data_json(&pb))
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
    fn every_tick_becomes_a_frame_with_its_band_and_bodies() {
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
        // The synthetic rack never moves: one set of movable bodies.
        assert_eq!(pb.body_sets.len(), 1);
        assert!(pb.frames.iter().all(|f| f.bodies == Some(0)));
        let j = data_json(&pb);
        assert!(
            j.starts_with("{\"frames\":[[0,0,0,0,0,-1,0],"),
            "{}",
            &j[..60]
        );
        assert!(j.ends_with("\"robot\":[0.508,0.43]}"));
    }
}
