//! ROS map_server maps in and out: a YAML description plus a PGM image.
//!
//! Reading follows map_server: with `negate: 0` a pixel's occupancy is
//! `p = (maxval - v) / maxval` (black = occupied), with `negate: 1` it is `v / maxval`;
//! `p > occupied_thresh` is occupied, `p < free_thresh` free. In `raw` mode `p = v / 100`.
//! Whatever is neither (map_server's "unknown", e.g. the grey 205 of map_saver) becomes
//! occupied here: the grid is binary, and unknown space is not safe to drive through.
//! Image row 0 is the top of the map (largest y); grid row 0 is the bottom.
//!
//! Writing produces what map_saver writes: occupied 0, free 254, trinary, negate 0.
//! Detected and static cells are both written occupied. Knows nothing of the scene.

mod pgm;
mod yaml;

pub use pgm::{MAX_PIXELS, Pgm, encode_p5, parse_pgm};
pub use yaml::{
    DEFAULT_FREE_THRESH, DEFAULT_OCCUPIED_THRESH, MapMode, MapYaml, format_map_yaml, parse_map_yaml,
};

use crate::error::MapError;
use aisle_geometry::{FREE, GridMap, GridView, OCCUPIED_STATIC};
use std::path::{Path, PathBuf};

fn read(file: &Path) -> Result<Vec<u8>, MapError> {
    std::fs::read(file).map_err(|source| MapError::Io {
        file: file.to_path_buf(),
        source,
    })
}

fn write(file: &Path, bytes: &[u8]) -> Result<(), MapError> {
    std::fs::write(file, bytes).map_err(|source| MapError::Io {
        file: file.to_path_buf(),
        source,
    })
}

/// Where the image of `yaml` lives: relative paths start at the YAML's directory.
pub fn image_path(yaml_path: &Path, yaml: &MapYaml) -> PathBuf {
    if yaml.image.is_absolute() {
        yaml.image.clone()
    } else {
        yaml_path
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(&yaml.image)
    }
}

/// Reads a map_server YAML and its image into a grid (`OCCUPIED_STATIC` / `FREE`).
pub fn read_ros_map(yaml_path: &Path) -> Result<GridMap, MapError> {
    let text = String::from_utf8(read(yaml_path)?)
        .map_err(|_| MapError::ros(yaml_path, None, None, "not UTF-8 text"))?;
    let yaml = parse_map_yaml(yaml_path, &text)?;
    let image = image_path(yaml_path, &yaml);
    let pgm = parse_pgm(&image, &read(&image)?)?;
    grid_from_image(&yaml, &pgm).map_err(|e| match e {
        MapError::Grid(g) => MapError::ros(yaml_path, None, Some("resolution"), g.to_string()),
        other => other,
    })
}

/// The grid an image describes under the YAML's thresholds.
pub fn grid_from_image(yaml: &MapYaml, img: &Pgm) -> Result<GridMap, MapError> {
    let maxval = f64::from(img.maxval);
    let occupancy = |v: u16| -> Option<f64> {
        let v = f64::from(v);
        match yaml.mode {
            MapMode::Raw => (v <= 100.0).then_some(v / 100.0),
            _ if yaml.negate => Some(v / maxval),
            _ => Some((maxval - v) / maxval),
        }
    };
    let (w, h) = (img.width, img.height);
    let mut cells = vec![OCCUPIED_STATIC; w * h];
    for row in 0..h {
        let gy = h - 1 - row;
        for col in 0..w {
            if let Some(p) = occupancy(img.pixels[row * w + col])
                && p < yaml.free_thresh
            {
                cells[gy * w + col] = FREE;
            }
        }
    }
    Ok(GridMap::from_cells(
        yaml.origin[0],
        yaml.origin[1],
        yaml.resolution,
        w,
        h,
        cells,
    )?)
}

/// The P5 image of a grid as map_saver draws it: occupied 0, free 254, top row first.
pub fn image_of_grid(grid: &GridView<'_>) -> Vec<u8> {
    let (w, h) = (grid.width, grid.height);
    let mut px = Vec::with_capacity(w * h);
    for row in 0..h {
        let gy = h - 1 - row;
        px.extend(
            grid.cells[gy * w..(gy + 1) * w]
                .iter()
                .map(|&c| if c == FREE { 254 } else { 0 }),
        );
    }
    encode_p5(w, h, &px)
}

/// Writes `grid` as `yaml_path` plus an image beside it with the same stem and `.pgm`;
/// returns the image's path.
pub fn write_ros_map(yaml_path: &Path, grid: &GridView<'_>) -> Result<PathBuf, MapError> {
    let stem = yaml_path
        .file_stem()
        .filter(|s| !s.is_empty())
        .ok_or_else(|| MapError::ros(yaml_path, None, None, "has no file name"))?;
    let image_name = PathBuf::from(stem).with_extension("pgm");
    let yaml = MapYaml {
        image: image_name.clone(),
        resolution: grid.resolution,
        origin: [grid.origin_x, grid.origin_y, 0.0],
        negate: false,
        occupied_thresh: DEFAULT_OCCUPIED_THRESH,
        free_thresh: DEFAULT_FREE_THRESH,
        mode: MapMode::Trinary,
    };
    let image = image_path(yaml_path, &yaml);
    write(&image, &image_of_grid(grid))?;
    write(yaml_path, format_map_yaml(&yaml).as_bytes())?;
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::MapConfig;
    use crate::static_map::static_map_from_scene;
    use aisle_config::scene::Scene;
    use aisle_geometry::{CellIndex, OCCUPIED_DETECTED};

    struct TempDir(PathBuf);
    impl TempDir {
        fn new(tag: &str) -> Self {
            let p = std::env::temp_dir().join(format!("aisle-mapper-{tag}-{}", std::process::id()));
            std::fs::create_dir_all(&p).unwrap();
            TempDir(p)
        }
    }
    impl Drop for TempDir {
        fn drop(&mut self) {
            std::fs::remove_dir_all(&self.0).ok();
        }
    }

    #[test]
    fn the_warehouse_map_round_trips() {
        let dir = TempDir::new("roundtrip");
        let scene_path = aisle_config::testing::shipped("warehouse.toml");
        let scene = Scene::load(&scene_path).unwrap();
        for cpm in [10.0, 20.0] {
            let cfg = MapConfig {
                cells_per_metre: cpm,
                ..MapConfig::default()
            };
            let mut g = static_map_from_scene(&scene, &cfg).unwrap();
            // A detection is written as occupied, and read back as static.
            g.set(g.view().cell_of(0.5, 0.5), OCCUPIED_DETECTED);
            let yaml = dir.0.join(format!("warehouse{cpm}.yaml"));
            let image = write_ros_map(&yaml, &g.view()).unwrap();
            assert!(image.ends_with(format!("warehouse{cpm}.pgm")));
            let back = read_ros_map(&yaml).unwrap();
            assert_eq!((back.width, back.height), (g.width, g.height));
            assert_eq!(back.resolution, g.resolution);
            assert_eq!((back.origin_x, back.origin_y), (g.origin_x, g.origin_y));
            let want: Vec<u8> = g
                .cells
                .iter()
                .map(|&c| if c == FREE { FREE } else { OCCUPIED_STATIC })
                .collect();
            assert_eq!(back.cells, want);
        }
    }

    #[test]
    fn image_rows_are_top_first_and_thresholds_apply() {
        // 2 x 2: top row black, white; bottom row grey (unknown), white.
        let yaml = MapYaml {
            image: "x.pgm".into(),
            resolution: 0.5,
            origin: [1.0, 2.0, 0.0],
            negate: false,
            occupied_thresh: 0.65,
            free_thresh: 0.196,
            mode: MapMode::Trinary,
        };
        let img = Pgm {
            width: 2,
            height: 2,
            maxval: 255,
            pixels: vec![0, 254, 205, 255],
        };
        let g = grid_from_image(&yaml, &img).unwrap();
        let at = |ix, iy| g.view().get(CellIndex { ix, iy }).unwrap();
        assert_eq!(
            at(0, 1),
            OCCUPIED_STATIC,
            "top-left black pixel is the top row"
        );
        assert_eq!(at(1, 1), FREE);
        assert_eq!(at(0, 0), OCCUPIED_STATIC, "unknown grey is occupied");
        assert_eq!(at(1, 0), FREE);
        assert!(g.view().occupied_at(1.2, 2.7));
        let negated = grid_from_image(
            &MapYaml {
                negate: true,
                ..yaml.clone()
            },
            &img,
        )
        .unwrap();
        assert_eq!(negated.view().get(CellIndex { ix: 0, iy: 1 }), Some(FREE));
        let raw = grid_from_image(
            &MapYaml {
                mode: MapMode::Raw,
                ..yaml
            },
            &Pgm {
                width: 3,
                height: 1,
                maxval: 255,
                pixels: vec![0, 100, 255],
            },
        )
        .unwrap();
        assert_eq!(raw.cells, vec![FREE, OCCUPIED_STATIC, OCCUPIED_STATIC]);
    }

    #[test]
    fn bad_files_are_errors_naming_them() {
        let dir = TempDir::new("bad");
        let yaml = dir.0.join("m.yaml");
        let e = read_ros_map(&yaml).unwrap_err().to_string();
        assert!(e.contains("m.yaml"), "{e}");
        std::fs::write(
            &yaml,
            "image: missing.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n",
        )
        .unwrap();
        let e = read_ros_map(&yaml).unwrap_err().to_string();
        assert!(e.contains("missing.pgm"), "{e}");
        std::fs::write(dir.0.join("missing.pgm"), b"P5 2 2 255\n\x00").unwrap();
        let e = read_ros_map(&yaml).unwrap_err().to_string();
        assert!(e.contains("missing.pgm") && e.contains("needs 4"), "{e}");
        std::fs::write(&yaml, b"image: a\xff\n").unwrap();
        let e = read_ros_map(&yaml).unwrap_err().to_string();
        assert!(e.contains("m.yaml") && e.contains("UTF-8"), "{e}");
        std::fs::write(&yaml, "image: m.pgm\nresolution: 0.1\norigin: [0, 0]\n").unwrap();
        let e = read_ros_map(&yaml).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}:3: key `origin`", yaml.display())),
            "{e}"
        );
    }
}
