//! `aisle map export <dir>`: the scene's static map written as ROS map_server files
//! (`<dir>/<name>.yaml` + `<dir>/<name>.pgm`), so it can be inspected or edited and
//! brought back through `ros_map` in `mapper.toml`.
//!
//! Always rasterises the scene, even when `mapper.toml` names a ROS map: the point is
//! to export what the scene gives. Knows nothing of the command line.

use crate::config::MapConfig;
use crate::error::MapError;
use crate::ros_map::write_ros_map;
use crate::static_map::static_map_from_scene;
use aisle_config::scene::Scene;
use std::path::{Path, PathBuf};

/// The two files an export wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportedMap {
    pub yaml: PathBuf,
    pub image: PathBuf,
}

/// Rasterises `scene` as `cfg` describes and writes it into `dir` (created if needed)
/// as `<name>.yaml` and `<name>.pgm`.
pub fn export_scene_map(
    scene: &Scene,
    cfg: &MapConfig,
    dir: &Path,
    name: &str,
) -> Result<ExportedMap, MapError> {
    aisle_config::Validate::validate(cfg)?;
    let grid = static_map_from_scene(scene, cfg)?;
    std::fs::create_dir_all(dir).map_err(|source| MapError::Io {
        file: dir.to_path_buf(),
        source,
    })?;
    let yaml = dir.join(format!("{name}.yaml"));
    let image = write_ros_map(&yaml, &grid.view())?;
    Ok(ExportedMap { yaml, image })
}

/// What the CLI calls: reads `mapper.toml` and `warehouse.toml` from `config_dir` and
/// exports the scene's static map into `dir` as `<name>.yaml` and `<name>.pgm`.
pub fn export_from_config_dir(
    config_dir: &Path,
    dir: &Path,
    name: &str,
) -> Result<ExportedMap, MapError> {
    let cfg = aisle_config::load::<MapConfig>(&config_dir.join("mapper.toml"))?;
    let scene = Scene::load(&config_dir.join("warehouse.toml"))?;
    export_scene_map(&scene, &cfg, dir, name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros_map::read_ros_map;

    fn config_dir() -> PathBuf {
        aisle_config::testing::shipped_dir()
    }

    #[test]
    fn the_exported_map_reads_back_as_the_scene_map() {
        let out = std::env::temp_dir().join(format!("aisle-mapper-export-{}", std::process::id()));
        std::fs::remove_dir_all(&out).ok();
        let dir = out.join("nested/dir");
        let files = export_from_config_dir(&config_dir(), &dir, "map").unwrap();
        assert_eq!(files.yaml, dir.join("map.yaml"));
        assert_eq!(files.image, dir.join("map.pgm"));
        let back = read_ros_map(&files.yaml).unwrap();
        let cfg = aisle_config::load::<MapConfig>(&config_dir().join("mapper.toml")).unwrap();
        let scene = Scene::load(&config_dir().join("warehouse.toml")).unwrap();
        let want = static_map_from_scene(&scene, &cfg).unwrap();
        assert_eq!((back.width, back.height), (200, 300));
        assert_eq!((back.origin_x, back.origin_y), (-5.0, -10.0));
        assert_eq!(back.cells, want.cells);
        std::fs::remove_dir_all(&out).ok();
    }

    #[test]
    fn a_missing_config_dir_or_unwritable_target_is_an_error() {
        let e = export_from_config_dir(Path::new("/nonexistent/cfg"), Path::new("/tmp"), "map")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/cfg/mapper.toml"), "{e}");
        // A regular file where the directory should be.
        let file =
            std::env::temp_dir().join(format!("aisle-mapper-export-file-{}", std::process::id()));
        std::fs::write(&file, b"x").unwrap();
        let e = export_from_config_dir(&config_dir(), &file, "map")
            .unwrap_err()
            .to_string();
        assert!(e.contains(&file.display().to_string()), "{e}");
        std::fs::remove_file(&file).ok();
    }
}
