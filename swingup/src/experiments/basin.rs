//! `swingup basin`: the balancing controller's region of attraction, its
//! calibrated level and a map of it around upright, against the box rule
//! ([`crate::plant::basin`]).

use serde::{Deserialize, Serialize};

use crate::config::Config;
use crate::plant::basin::{BasinSettings, Catch, CatchRule, robot_basin};
use crate::plant::demo::demonstration;
use crate::plant::from_upright;
use crate::plant::lqr::Lqr;

/// Angles from upright of the map's columns: -1.2 to 1.2 rad.
const MAP_ANGLES: usize = 25;
/// Angular speeds of the map's rows: 8 to -8 rad/s.
const MAP_RATES: usize = 17;
/// Noise seeds a map cell (and a box state) must balance on.
const NOISE_SEEDS: u64 = 3;

/// What `swingup basin` measures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BasinReport {
    /// The commit the program was built from.
    pub version: String,
    /// The calibrated level $c$ of $e^\top P e$.
    pub level: f64,
    /// $V_\max$ of the calibration's last round.
    pub sampled_to: f64,
    /// Calibration samples of that round.
    pub samples: usize,
    /// Of those, with $V < c$.
    pub inside: usize,
    /// Of those, balanced.
    pub balanced_inside: usize,
    /// The hand state $(x, \dot x)$ of the map and of the box count: the
    /// demonstration's when the box rule first holds (the end of a
    /// swing-up), or the origin.
    pub hand: [f64; 2],
    /// States of the box rule's grid (angle from upright -0.3 to 0.3 rad by
    /// 0.05, speed -2 to 2 rad/s by 0.5; the box's limits from `cfg`) at
    /// that hand state.
    pub box_states: usize,
    /// Of those, balanced on every noise seed.
    pub box_balanced: usize,
    /// Of those box states, inside the calibrated level.
    pub box_inside_level: usize,
    /// Cells of the map balanced on every noise seed.
    pub map_balanced: usize,
    /// Cells of the map inside the level.
    pub map_inside: usize,
    /// Cells inside the level not balanced on every noise seed.
    pub map_inside_failing: usize,
    /// The map: one string per speed (8 to -8 rad/s), one character per
    /// angle (-1.2 to 1.2 rad): `#` inside the level and balanced, `X`
    /// inside but not balanced, `+` balanced outside it, `.` neither.
    pub map: Vec<String>,
}

/// Calibrates the catch for `cfg`'s robot and maps it.
///
/// # Errors
/// An invalid configuration, a controller that cannot be designed, or no
/// basin found.
pub fn basin_report(cfg: &Config, settings: &BasinSettings) -> crate::Result<BasinReport> {
    cfg.validate()?;
    let lqr = Lqr::balancing(&cfg.robot, "robot")?;
    let basin = robot_basin(&lqr, &cfg.balance_test(), settings)?;
    let test = cfg.balance_test();
    let catch = Catch {
        lqr,
        rule: CatchRule::Basin { level: basin.level },
    };
    let demo = demonstration(&cfg.human, &cfg.human_swingup, cfg.horizon, cfg.balance)?;
    let hand = demo
        .states
        .iter()
        .find(|s| from_upright(s[0]).abs() < cfg.catch_angle && s[1].abs() < cfg.catch_rate)
        .map_or([0.0, 0.0], |s| [s[2], s[3]]);
    let balanced = |angle: f64, rate: f64| {
        let s = [std::f64::consts::PI + angle, rate, hand[0], hand[1]];
        (1..=NOISE_SEEDS).all(|seed| test.balances(&lqr, &s, settings.seed.wrapping_add(seed)))
    };
    let at = |angle: f64, rate: f64| [std::f64::consts::PI + angle, rate, hand[0], hand[1]];
    // the box's grid
    let (mut box_states, mut box_balanced, mut box_inside_level) = (0, 0, 0);
    for i in -6..=6 {
        for j in -4..=4 {
            let (angle, rate) = (0.05 * f64::from(i), 0.5 * f64::from(j));
            if angle.abs() >= cfg.catch_angle || rate.abs() >= cfg.catch_rate {
                continue;
            }
            box_states += 1;
            box_balanced += usize::from(balanced(angle, rate));
            box_inside_level += usize::from(catch.holds(&at(angle, rate)));
        }
    }
    let (mut map, mut map_balanced, mut map_inside, mut map_inside_failing) = (Vec::new(), 0, 0, 0);
    for r in 0..MAP_RATES {
        let rate = 8.0 - 16.0 * r as f64 / (MAP_RATES - 1) as f64;
        let mut line = String::with_capacity(MAP_ANGLES);
        for a in 0..MAP_ANGLES {
            let angle = -1.2 + 2.4 * a as f64 / (MAP_ANGLES - 1) as f64;
            let ok = balanced(angle, rate);
            let inside = catch.holds(&at(angle, rate));
            map_balanced += usize::from(ok);
            map_inside += usize::from(inside);
            map_inside_failing += usize::from(inside && !ok);
            line.push(match (inside, ok) {
                (true, true) => '#',
                (true, false) => 'X',
                (false, true) => '+',
                (false, false) => '.',
            });
        }
        map.push(line);
    }
    Ok(BasinReport {
        version: store::code_version().to_string(),
        level: basin.level,
        sampled_to: basin.sampled_to,
        samples: basin.samples.len(),
        inside: basin.inside,
        balanced_inside: basin.balanced_inside,
        hand,
        box_states,
        box_balanced,
        box_inside_level,
        map_balanced,
        map_inside,
        map_inside_failing,
        map,
    })
}

impl BasinReport {
    /// The report as Markdown.
    pub fn markdown(&self) -> String {
        let mut md = String::from("# The balancing controller's basin\n\n");
        md.push_str(&format!(
            "Made by `swingup basin` at {}. The LQR takes over (`catch = \"basin\"`) where its cost to go \
             $e^\\top P e$ is below the level c = {:.1}: of {} states drawn uniformly from $e^\\top P e \\le {:.0}$ \
             and run as a balancing phase on the robot (its sensor noise, actuator limit and workspace), {} were \
             below the level and {} of those were balanced ({:.1} %).\n\n",
            self.version,
            self.level,
            self.samples,
            self.sampled_to,
            self.inside,
            self.balanced_inside,
            100.0 * self.balanced_inside as f64 / self.inside.max(1) as f64
        ));
        md.push_str(&format!(
            "With the hand at x = {:.3} m, x' = {:.3} m/s (the demonstration's when the box first holds): \
             the box rule's grid holds {} states, of which {} are balanced on all {} noise seeds and {} are \
             inside the level.\n\n",
            self.hand[0], self.hand[1], self.box_states, self.box_balanced, NOISE_SEEDS, self.box_inside_level
        ));
        md.push_str(&format!(
            "Map at that hand state (columns: angle from upright -1.2 to 1.2 rad; rows: angular speed 8 to -8 \
             rad/s; `#` inside the level and balanced on every noise seed, `X` inside but not, `+` balanced \
             outside it, `.` neither): {} of {} cells balanced, {} inside the level, {} of those failing.\n\n```\n",
            self.map_balanced,
            MAP_ANGLES * MAP_RATES,
            self.map_inside,
            self.map_inside_failing
        ));
        for line in &self.map {
            md.push_str(line);
            md.push('\n');
        }
        md.push_str("```\n");
        md
    }
}
