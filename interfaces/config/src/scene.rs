//! The warehouse scene (`config/warehouse.toml`): named bodies made of boxes.
//!
//! A body has a planar pose (x, y, yaw) and one or more axis-aligned boxes in its own
//! frame (z measured up from the floor). A body is either static (it is on the map) or
//! movable (pallet racks, unseen pallets, loose boxes: only the lidar finds them).
//! Compound shapes such as a pallet rack (four legs, a deck, boxes on it) are written
//! once as a template. This module knows geometry only; who sees which body is decided
//! by the mapper (static only), the lidar (all) and the simulator (all, for collisions).

use crate::ConfigError;
use aisle_geometry::{Footprint, Pose2};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;

/// A box of a body, in the body's frame: centre (x, y, z) and full size (x, y, z).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxPart {
    pub center: [f64; 3],
    pub size: [f64; 3],
}

impl BoxPart {
    pub fn z_min(&self) -> f64 {
        self.center[2] - 0.5 * self.size[2]
    }
    pub fn z_max(&self) -> f64 {
        self.center[2] + 0.5 * self.size[2]
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TemplateSpec {
    parts: Vec<BoxPart>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct BodySpec {
    name: String,
    kind: String,
    #[serde(rename = "static")]
    is_static: bool,
    /// x, y, yaw (radians) of the body frame in the map frame.
    pose: [f64; 3],
    /// A single box standing on the floor, centred on the pose.
    size: Option<[f64; 3]>,
    /// Or a template of several boxes.
    template: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    templates: BTreeMap<String, TemplateSpec>,
    body: Vec<BodySpec>,
}

/// One body of the scene, resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    pub name: String,
    /// Free-form category: wall, rack_row, shelf, table, pallet_rack, eur_pallet, box.
    pub kind: String,
    pub is_static: bool,
    pub pose: Pose2,
    pub parts: Vec<BoxPart>,
}

impl Body {
    /// Smallest rectangle in the body frame, centred on the pose, that covers every part.
    pub fn footprint(&self) -> Footprint {
        let mut hx: f64 = 0.0;
        let mut hy: f64 = 0.0;
        for p in &self.parts {
            hx = hx.max(p.center[0].abs() + 0.5 * p.size[0]);
            hy = hy.max(p.center[1].abs() + 0.5 * p.size[1]);
        }
        Footprint::new(2.0 * hx, 2.0 * hy)
    }

    pub fn height(&self) -> f64 {
        self.parts.iter().map(BoxPart::z_max).fold(0.0, f64::max)
    }
}

/// The whole warehouse.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub bodies: Vec<Body>,
}

impl Scene {
    pub fn load(path: &Path) -> Result<Scene, ConfigError> {
        let (file, text) = crate::load_toml::<SceneFile>(path)?;
        resolve(path, &text, file)
    }

    pub fn parse(path: &Path, text: &str) -> Result<Scene, ConfigError> {
        let file = crate::parse_toml::<SceneFile>(path, text)?;
        resolve(path, text, file)
    }

    pub fn body(&self, name: &str) -> Option<(usize, &Body)> {
        self.bodies.iter().enumerate().find(|(_, b)| b.name == name)
    }

    pub fn static_bodies(&self) -> impl Iterator<Item = &Body> {
        self.bodies.iter().filter(|b| b.is_static)
    }

    pub fn movable_bodies(&self) -> impl Iterator<Item = &Body> {
        self.bodies.iter().filter(|b| !b.is_static)
    }
}

fn positive_size(size: &[f64; 3]) -> bool {
    size.iter().all(|s| s.is_finite() && *s > 0.0)
}

fn resolve(path: &Path, text: &str, file: SceneFile) -> Result<Scene, ConfigError> {
    check_templates(path, text, &file.templates)?;
    let mut bodies = Vec::with_capacity(file.body.len());
    let mut seen = BTreeMap::new();
    for (i, b) in file.body.into_iter().enumerate() {
        let key = |k: &str| format!("body[{i}].{k}");
        if b.name.is_empty() {
            return Err(ConfigError::invalid(path, text, &key("name"), "empty name"));
        }
        if let Some(first) = seen.insert(b.name.clone(), i) {
            return Err(ConfigError::invalid(
                path,
                text,
                &key("name"),
                format!("`{}` is also the name of body {first}", b.name),
            ));
        }
        if !b.pose.iter().all(|v| v.is_finite()) {
            return Err(ConfigError::invalid(
                path,
                text,
                &key("pose"),
                format!("not finite: {:?}", b.pose),
            ));
        }
        let parts = body_parts(path, text, i, &b, &file.templates)?;
        bodies.push(Body {
            name: b.name,
            kind: b.kind,
            is_static: b.is_static,
            pose: Pose2::new(b.pose[0], b.pose[1], b.pose[2]),
            parts,
        });
    }
    if bodies.is_empty() {
        return Err(ConfigError::invalid(
            path,
            text,
            "body",
            "the scene has no bodies",
        ));
    }
    Ok(Scene { bodies })
}

/// Every template has parts, each of positive, finite size at a finite centre.
fn check_templates(
    path: &Path,
    text: &str,
    templates: &BTreeMap<String, TemplateSpec>,
) -> Result<(), ConfigError> {
    for (name, t) in templates {
        if t.parts.is_empty() {
            return Err(ConfigError::invalid(
                path,
                text,
                &format!("templates.{name}.parts"),
                "a template needs at least one part",
            ));
        }
        for (i, p) in t.parts.iter().enumerate() {
            if !positive_size(&p.size) || !p.center.iter().all(|c| c.is_finite()) {
                return Err(ConfigError::invalid(
                    path,
                    text,
                    &format!("templates.{name}.parts"),
                    format!(
                        "part {i}: sizes must be positive and finite, got {:?}",
                        p.size
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The boxes of body `i`: its one `size` box standing on the floor, or its template's.
fn body_parts(
    path: &Path,
    text: &str,
    i: usize,
    b: &BodySpec,
    templates: &BTreeMap<String, TemplateSpec>,
) -> Result<Vec<BoxPart>, ConfigError> {
    let key = |k: &str| format!("body[{i}].{k}");
    match (&b.size, &b.template) {
        (Some(size), None) => {
            if !positive_size(size) {
                return Err(ConfigError::invalid(
                    path,
                    text,
                    &key("size"),
                    format!("sizes must be positive, got {size:?}"),
                ));
            }
            Ok(vec![BoxPart {
                center: [0.0, 0.0, 0.5 * size[2]],
                size: *size,
            }])
        }
        (None, Some(t)) => match templates.get(t) {
            Some(t) => Ok(t.parts.clone()),
            None => Err(ConfigError::invalid(
                path,
                text,
                &key("template"),
                format!("no template named `{t}`"),
            )),
        },
        _ => Err(ConfigError::invalid(
            path,
            text,
            &key("name"),
            format!(
                "body `{}` needs exactly one of `size` or `template`",
                b.name
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"
[templates.rack]
parts = [
  { center = [0.4, 0.35, 0.15], size = [0.05, 0.05, 0.3] },
  { center = [0.0, 0.0, 0.325], size = [0.88, 0.8, 0.05] },
]

[[body]]
name = "wall"
kind = "wall"
static = true
pose = [0.0, 0.0, 0.0]
size = [10.0, 0.2, 3.0]

[[body]]
name = "rack1"
kind = "pallet_rack"
static = false
pose = [2.0, 3.0, 1.0]
template = "rack"
"#;

    #[test]
    fn bodies_resolve_with_templates() {
        let s = Scene::parse(Path::new("w.toml"), SMALL).unwrap();
        assert_eq!(s.bodies.len(), 2);
        assert_eq!(s.static_bodies().count(), 1);
        let (i, rack) = s.body("rack1").unwrap();
        assert_eq!(i, 1);
        assert_eq!(rack.parts.len(), 2);
        let fp = rack.footprint();
        assert!((fp.length - 0.88).abs() < 1e-12 && (fp.width - 0.8).abs() < 1e-12);
        assert!((s.bodies[0].height() - 3.0).abs() < 1e-12);
    }

    #[test]
    fn negative_size_names_body_key_and_line() {
        let bad = SMALL.replace("size = [10.0, 0.2, 3.0]", "size = [10.0, -0.2, 3.0]");
        let e = Scene::parse(Path::new("w.toml"), &bad)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("w.toml:13:") && e.contains("body[0].size"),
            "{e}"
        );
    }

    #[test]
    fn unknown_template_and_duplicate_names_are_refused() {
        let bad = SMALL.replace("template = \"rack\"", "template = \"shelf\"");
        assert!(
            Scene::parse(Path::new("w.toml"), &bad)
                .unwrap_err()
                .to_string()
                .contains("no template named `shelf`")
        );
        let dup = SMALL.replace("name = \"rack1\"", "name = \"wall\"");
        assert!(
            Scene::parse(Path::new("w.toml"), &dup)
                .unwrap_err()
                .to_string()
                .contains("also the name")
        );
    }

    #[test]
    fn unknown_key_is_refused() {
        let bad = SMALL.replace("kind = \"wall\"", "kind = \"wall\"\ncolour = \"red\"");
        let e = Scene::parse(Path::new("w.toml"), &bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains("colour"), "{e}");
    }
}

#[cfg(test)]
mod shipped_scene {
    use super::*;

    #[test]
    fn the_shipped_warehouse_loads_and_matches_the_scenario() {
        let path = crate::testing::shipped("warehouse.toml");
        let s = Scene::load(&path).unwrap();
        assert_eq!(
            s.movable_bodies().count(),
            16,
            "16 movable bodies plus the robot: the seed's 17 platforms"
        );
        let (_, rack) = s.body("rack2b").unwrap();
        assert!(!rack.is_static);
        assert_eq!((rack.pose.x, rack.pose.y), (2.0, 13.0));
        for b in s
            .bodies
            .iter()
            .filter(|b| b.kind == "pallet_rack" || b.kind == "eur_pallet" || b.kind == "box")
        {
            assert!(!b.is_static, "{} must never be on the map", b.name);
        }
    }
}
