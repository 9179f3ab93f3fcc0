//! `aisle scenario generate`: a complete config directory varied from a base one,
//! deterministically from (seed, family). The families ([`Family`]) move or add unseen
//! obstacles, move the start, leave a narrow gap, make another mission, or make the
//! mission infeasible; every generated directory passes `aisle check`
//! ([`crate::check::check_dir`]) or is drawn again.
//!
//! - [`ground`]: the base directory loaded, the layout of bodies, the clearances.
//! - [`geom`]: rectangles, overlap and rays.
//! - [`route`]: where a robot will drive, roughly (grid route on the static map).
//! - [`sample`]: seeded poses and sizes, free poses.
//! - [`families`] and [`barriers`]: what each family varies.
//! - [`write`]: the directory on disk, and its oracle (unseen bodies made static).
//!
//! Knows the config files; knows nothing of running them (that is [`crate::sweep`]).

pub mod barriers;
pub mod families;
pub mod geom;
pub mod ground;
pub mod route;
pub mod sample;
pub mod write;

use aisle_geometry::Pose2;
use ground::{Ground, Layout};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
#[cfg(test)]
use std::path::Path;
use std::path::PathBuf;

/// What a scenario varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Family {
    /// The unseen pallets, boxes and carts moved along the corridors.
    Moved,
    /// Extra unseen boxes and carts, some on the way the robot will drive.
    Extra,
    /// Another start pose, anywhere free.
    Start,
    /// An unseen barrier across the carry leg's way leaving a gap just wider than the
    /// carrying footprint plus its margin.
    Gap,
    /// Another mission: another rack, side, drop pose and heading, park pose.
    Mission,
    /// A drop or park pose enclosed by unseen obstacles, or a gap too narrow to carry
    /// the rack through.
    Infeasible,
}

impl Family {
    pub const ALL: [Family; 6] = [
        Family::Moved,
        Family::Extra,
        Family::Start,
        Family::Gap,
        Family::Mission,
        Family::Infeasible,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Family::Moved => "moved",
            Family::Extra => "extra",
            Family::Start => "start",
            Family::Gap => "gap",
            Family::Mission => "mission",
            Family::Infeasible => "infeasible",
        }
    }

    pub fn parse(s: &str) -> Result<Family, String> {
        Family::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = Family::ALL.iter().map(|f| f.name()).collect();
                format!("no scenario family `{s}` (one of {})", names.join(", "))
            })
    }
}

/// One mission leg as the generator writes it (`goal` None: an approach leg whose
/// heading the planner chooses).
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    pub name: String,
    pub goal: Option<[f64; 3]>,
    pub rotate: bool,
    pub carry: Option<String>,
    pub approach: Option<String>,
    pub depart: Option<f64>,
    pub max_velocity: Option<[f64; 2]>,
}

/// A body the generator adds: one box standing on the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct NewBody {
    pub name: String,
    pub kind: String,
    pub pose: Pose2,
    pub size: [f64; 3],
}

/// The changes a family makes to the base directory.
#[derive(Debug, Clone)]
pub struct Draft {
    pub layout: Layout,
    /// Existing bodies at new poses.
    pub moved: Vec<(String, Pose2)>,
    pub added: Vec<NewBody>,
    pub start: Pose2,
    pub legs: Vec<Leg>,
    /// What was varied, one line each, for the files' header.
    pub varied: Vec<String>,
}

impl Draft {
    /// The base directory unchanged, with the mission's areas kept free.
    pub fn base(g: &Ground) -> Draft {
        let legs: Vec<Leg> = g
            .mission
            .leg
            .iter()
            .map(|l| Leg {
                name: l.name.clone(),
                goal: l.goal_given,
                rotate: l.rotate,
                carry: l.carry.clone(),
                approach: l.approach.clone(),
                depart: l.depart,
                max_velocity: l.max_velocity,
            })
            .collect();
        let start = g.mission.start_pose();
        let mut layout = g.layout();
        // An unfit base mission keeps nothing free: its start is drawn anew.
        if g.mission_unfit.is_none() {
            layout.keep_out = sample::keep_out(g, start, &legs);
        }
        Draft {
            layout,
            moved: Vec::new(),
            added: Vec::new(),
            start,
            legs,
            varied: Vec::new(),
        }
    }

    /// Adds an obstacle to the files and the layout.
    pub fn add(&mut self, body: NewBody) {
        self.layout.bodies.push(ground::Placed {
            name: body.name.clone(),
            kind: body.kind.clone(),
            is_static: false,
            rect: geom::Rect::new(
                body.pose,
                aisle_geometry::Footprint::new(body.size[0], body.size[1]),
            ),
        });
        self.added.push(body);
    }

    /// Bodies the mission names (picks or carries).
    pub fn named(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .legs
            .iter()
            .flat_map(|l| l.approach.iter().chain(l.carry.iter()).cloned())
            .collect();
        names.sort();
        names.dedup();
        names
    }
}

#[derive(Debug, Clone)]
pub struct GenerateOptions {
    pub seed: u64,
    pub family: Family,
    pub out: PathBuf,
    pub base: PathBuf,
}

/// What was generated.
#[derive(Debug, Clone)]
pub struct Generated {
    pub dir: PathBuf,
    pub varied: Vec<String>,
    /// Draws that were refused (no room, or `check` said no) before this one.
    pub redraws: u32,
}

/// Draws before the generator gives up on a (seed, family).
const ATTEMPTS: u32 = 40;

/// The generator for one draw: ChaCha8 (stable across platforms and versions of
/// `rand`) keyed by seed, family and attempt.
pub fn rng_for(seed: u64, family: Family, attempt: u32) -> ChaCha8Rng {
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..8 + family.name().len()].copy_from_slice(family.name().as_bytes());
    key[28..].copy_from_slice(&attempt.to_le_bytes());
    ChaCha8Rng::from_seed(key)
}

/// Writes the scenario (seed, family) into `opts.out`; a directory that fails `aisle
/// check` is drawn again.
pub fn generate(opts: &GenerateOptions) -> Result<Generated, String> {
    let g = Ground::load(&opts.base).map_err(|e| format!("the base config: {e}"))?;
    generate_from(&g, opts)
}

/// [`generate`] from a base directory already loaded (a sweep loads it once).
pub fn generate_from(g: &Ground, opts: &GenerateOptions) -> Result<Generated, String> {
    if let Some(why) = g.unfit_for(opts.family) {
        return Err(why);
    }
    let mut last = String::from("no room for it in this scene");
    for attempt in 0..ATTEMPTS {
        let mut rng = rng_for(opts.seed, opts.family, attempt);
        let mut draft = Draft::base(g);
        let built = match opts.family {
            Family::Moved => families::moved(g, &mut rng, &mut draft),
            Family::Extra => families::extra(g, &mut rng, &mut draft),
            Family::Start => families::start(g, &mut rng, &mut draft),
            Family::Mission => families::mission(g, &mut rng, &mut draft),
            Family::Gap => barriers::gap(g, &mut rng, &mut draft),
            Family::Infeasible => barriers::infeasible(g, &mut rng, &mut draft),
        };
        if !built {
            continue;
        }
        let header = write::Header {
            family: opts.family,
            seed: opts.seed,
            varied: &draft.varied,
        };
        write::write_dir(&opts.base, &opts.out, &draft, &header)?;
        match crate::check::check_dir(&opts.out) {
            Ok(_) => {
                return Ok(Generated {
                    dir: opts.out.clone(),
                    varied: draft.varied,
                    redraws: attempt,
                });
            }
            Err(e) => last = e,
        }
    }
    Err(format!(
        "scenario {} seed {}: no valid draw in {ATTEMPTS} attempts; the last: {last}",
        opts.family.name(),
        opts.seed
    ))
}

#[cfg(test)]
mod tests;
