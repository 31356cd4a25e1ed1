//! One part of a grid of runs, for N machines or a batch scheduler's job
//! array: the contract `swingup experiments` and `nprl-bench` share.
//!
//! A grid's runs have a fixed order; shard $K$ of $N$ takes the runs at
//! positions $p$ with $p \bmod N = K - 1$, so every run belongs to exactly
//! one shard and the shards are about equally long. A shard is named on
//! the command line (`--shard 2/4`) or, when the option is absent inside a
//! Slurm job array, taken from the array's variables ([`Shard::resolve`]):
//!
//! | variable | meaning |
//! |---|---|
//! | `SLURM_ARRAY_TASK_ID` | this task's index in the array |
//! | `SLURM_ARRAY_TASK_MIN`, `SLURM_ARRAY_TASK_MAX` | the array's first and last index |
//! | `SLURM_ARRAY_TASK_COUNT` | the number of tasks |
//!
//! The array must be contiguous (`--array=0-3` or `--array=1-8`, a `%`
//! limit allowed): shard $K$ is `ID - MIN + 1` of `MAX - MIN + 1`, and a
//! stepped or listed array (`--array=0-6:2`, `--array=1,5`), whose task
//! count differs from `MAX - MIN + 1`, is refused rather than leaving runs
//! to no task.
//!
//! ```
//! use store::Shard;
//!
//! let shard: Shard = "2/3".parse().unwrap();
//! let mine: Vec<usize> = (0..7).filter(|&p| shard.contains(p)).collect();
//! assert_eq!(mine, [1, 4]);
//! assert_eq!(shard.to_string(), "2/3");
//! assert_eq!(shard.file_suffix(), "-2-of-3");
//!
//! // inside `sbatch --array=0-3`, task 2 is shard 3 of 4
//! let env = |k: &str| match k {
//!     "SLURM_ARRAY_TASK_ID" => Some("2".to_string()),
//!     "SLURM_ARRAY_TASK_MIN" => Some("0".to_string()),
//!     "SLURM_ARRAY_TASK_MAX" => Some("3".to_string()),
//!     "SLURM_ARRAY_TASK_COUNT" => Some("4".to_string()),
//!     _ => None,
//! };
//! assert_eq!(Shard::from_env_with(env).unwrap(), Some("3/4".parse().unwrap()));
//! ```

use serde::{Deserialize, Serialize};

/// One of `count` parts of a grid (`index` from 1 to `count`): the runs
/// whose position in the grid's fixed order is `index - 1` modulo `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Shard {
    /// This part, from 1.
    pub index: usize,
    /// Number of parts.
    pub count: usize,
}

/// A shard that cannot be read: from the command line or from the Slurm
/// variables, named.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{origin}: {message}")]
pub struct ShardError {
    /// Where the shard was read: `--shard`, or the Slurm variable.
    pub origin: String,
    /// What is wrong with it.
    pub message: String,
}

impl Shard {
    /// Whether the run at `position` (from 0) of the grid's order belongs
    /// to this part.
    pub fn contains(&self, position: usize) -> bool {
        position % self.count == self.index - 1
    }

    /// `-K-of-N`: what this part's files add to the grid's names
    /// (`runs-2-of-4.jsonl`).
    pub fn file_suffix(&self) -> String {
        format!("-{}-of-{}", self.index, self.count)
    }

    /// The shard a file name's suffix names (`-2-of-4` in
    /// `runs-2-of-4.jsonl`), strictly: `None` for anything but the form
    /// [`Shard::file_suffix`] writes (no leading zeros, $1 \le K \le N$).
    pub fn from_file_suffix(suffix: &str) -> Option<Self> {
        let (k, n) = suffix.strip_prefix('-')?.split_once("-of-")?;
        let shard: Shard = format!("{k}/{n}").parse().ok()?;
        (shard.file_suffix() == suffix).then_some(shard)
    }

    /// The shard of this process: `explicit` (from `--shard`) when given,
    /// otherwise the Slurm job array's task ([`Shard::from_env_with`] on the
    /// process's environment), otherwise none.
    ///
    /// # Errors
    /// The Slurm variables are set but malformed, or name a stepped or
    /// listed array.
    pub fn resolve(explicit: Option<Shard>) -> Result<Option<Shard>, ShardError> {
        match explicit {
            Some(s) => Ok(Some(s)),
            None => Self::from_env_with(|k| std::env::var(k).ok()),
        }
    }

    /// The shard of a Slurm job array's task, read through `var` (the
    /// environment, or a map in tests): `None` outside a job array (no
    /// `SLURM_ARRAY_TASK_ID`).
    ///
    /// # Errors
    /// A variable that is missing or not a number (named), an ID outside
    /// `MIN..=MAX`, or a task count other than `MAX - MIN + 1` (a stepped
    /// or listed array, which sharding by index cannot cover).
    pub fn from_env_with(var: impl Fn(&str) -> Option<String>) -> Result<Option<Shard>, ShardError> {
        const ID: &str = "SLURM_ARRAY_TASK_ID";
        let Some(id_text) = var(ID) else {
            return Ok(None);
        };
        let number = |name: &str, text: Option<String>| -> Result<usize, ShardError> {
            let text = text.ok_or_else(|| ShardError {
                origin: name.into(),
                message: format!("not set, though {ID} is (a job array's variables are set together)"),
            })?;
            text.trim().parse().map_err(|_| ShardError {
                origin: name.into(),
                message: format!("not a task index: {text:?}"),
            })
        };
        let id = number(ID, Some(id_text))?;
        let min = number("SLURM_ARRAY_TASK_MIN", var("SLURM_ARRAY_TASK_MIN"))?;
        let max = number("SLURM_ARRAY_TASK_MAX", var("SLURM_ARRAY_TASK_MAX"))?;
        if !(min <= id && id <= max) {
            return Err(ShardError {
                origin: ID.into(),
                message: format!("{id} is outside the array's range {min}-{max}"),
            });
        }
        let count = max - min + 1;
        if let Some(text) = var("SLURM_ARRAY_TASK_COUNT") {
            let n = number("SLURM_ARRAY_TASK_COUNT", Some(text))?;
            if n != count {
                return Err(ShardError {
                    origin: "SLURM_ARRAY_TASK_COUNT".into(),
                    message: format!(
                        "{n} tasks in the range {min}-{max}: a stepped or listed array leaves runs to no \
                         task; submit a contiguous one (--array={min}-{max}), or pass --shard K/N"
                    ),
                });
            }
        }
        Ok(Some(Shard {
            index: id - min + 1,
            count,
        }))
    }

    /// The shards whose files (`STEM-K-of-N.EXT`) are in `dir`, in name
    /// order; none when `dir` cannot be listed.
    pub fn found_in(dir: &std::path::Path, stem: &str, ext: &str) -> Vec<Shard> {
        let mut found: Vec<Shard> = std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .filter_map(|e| {
                let name = e.ok()?.file_name().into_string().ok()?;
                Shard::from_file_suffix(name.strip_prefix(stem)?.strip_suffix(ext)?)
            })
            .collect();
        found.sort_unstable();
        found
    }

    /// Refuses a shard taken from a Slurm array (`from_env`) whose count
    /// differs from the shards already in `dir` (`STEM-K-of-N.EXT`): a
    /// single task submitted again as `--array=K` is shard 1 of 1 by the
    /// array's variables, and would run the whole grid beside the others.
    ///
    /// # Errors
    /// The counts differ; the message says to pass `--shard K/N`.
    pub fn check_count_in(self, dir: &std::path::Path, stem: &str, ext: &str) -> Result<(), ShardError> {
        match Self::found_in(dir, stem, ext)
            .into_iter()
            .find(|s| s.count != self.count)
        {
            None => Ok(()),
            Some(other) => Err(ShardError {
                origin: "SLURM_ARRAY_TASK_COUNT".into(),
                message: format!(
                    "this task is shard {self} by the array's variables, but {} holds shards of {} (e.g. \
                     {stem}{}{ext}): a task submitted again alone (--array=K) cannot tell the array's size; \
                     pass --shard K/{}, or submit the whole array again (finished shards end at once)",
                    dir.display(),
                    other.count,
                    other.file_suffix(),
                    other.count
                ),
            }),
        }
    }

    /// The shards missing from `present` for each count it holds: `(N,
    /// [K, ...])` for every N with a part of N absent, in order.
    pub fn missing(present: &[Shard]) -> Vec<(usize, Vec<usize>)> {
        let mut counts: Vec<usize> = present.iter().map(|s| s.count).collect();
        counts.sort_unstable();
        counts.dedup();
        counts
            .into_iter()
            .filter_map(|n| {
                let absent: Vec<usize> = (1..=n)
                    .filter(|&k| !present.contains(&Shard { index: k, count: n }))
                    .collect();
                (!absent.is_empty()).then_some((n, absent))
            })
            .collect()
    }
}

impl std::fmt::Display for Shard {
    /// `K/N`, as `--shard` takes it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N` with $1 \le K \le N$.
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || format!("a shard is K/N with 1 <= K <= N (e.g. 2/4), got {text:?}");
        let (k, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let pairs: Vec<(String, String)> = pairs.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        move |k| pairs.iter().find(|(name, _)| name == k).map(|(_, v)| v.clone())
    }

    #[test]
    fn shards_split_every_grid_once() {
        for n in 1..=7 {
            let shards: Vec<Shard> = (1..=n).map(|k| Shard { index: k, count: n }).collect();
            for p in 0..50 {
                assert_eq!(shards.iter().filter(|s| s.contains(p)).count(), 1, "{p} of {n}");
            }
        }
    }

    #[test]
    fn slurm_arrays_map_to_shards_and_bad_ones_are_named() {
        let ok = |id, min, max, count| {
            Shard::from_env_with(env(&[
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_MIN", min),
                ("SLURM_ARRAY_TASK_MAX", max),
                ("SLURM_ARRAY_TASK_COUNT", count),
            ]))
        };
        assert_eq!(ok("0", "0", "3", "4"), Ok(Some(Shard { index: 1, count: 4 })));
        assert_eq!(ok("8", "1", "8", "8"), Ok(Some(Shard { index: 8, count: 8 })));
        assert_eq!(Shard::from_env_with(env(&[])), Ok(None));
        let stepped = ok("2", "0", "6", "4").expect_err("refused");
        assert_eq!(stepped.origin, "SLURM_ARRAY_TASK_COUNT");
        assert!(stepped.message.contains("stepped"), "{stepped}");
        assert_eq!(
            ok("x", "0", "3", "4").expect_err("refused").origin,
            "SLURM_ARRAY_TASK_ID"
        );
        assert_eq!(
            ok("5", "0", "3", "4").expect_err("refused").origin,
            "SLURM_ARRAY_TASK_ID"
        );
        let no_max = Shard::from_env_with(env(&[("SLURM_ARRAY_TASK_ID", "1"), ("SLURM_ARRAY_TASK_MIN", "0")]));
        assert_eq!(no_max.expect_err("refused").origin, "SLURM_ARRAY_TASK_MAX");
        // --shard wins over the environment
        let explicit = Shard { index: 2, count: 2 };
        assert_eq!(Shard::resolve(Some(explicit)), Ok(Some(explicit)));
    }

    #[test]
    fn names_parse_strictly_and_missing_shards_are_listed() {
        assert_eq!(Shard::from_file_suffix("-2-of-4"), Some(Shard { index: 2, count: 4 }));
        for bad in ["-02-of-4", "-5-of-4", "-0-of-4", "2-of-4", "-2-of-4x", ""] {
            assert_eq!(Shard::from_file_suffix(bad), None, "{bad}");
        }
        for bad in ["0/3", "4/3", "1", "a/b", "1/0"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let s = |k, n| Shard { index: k, count: n };
        let dir = crate::ScratchDir::new("shard-found").expect("scratch");
        for name in [
            "runs-2-of-4.jsonl",
            "runs-1-of-4.jsonl",
            "runs.jsonl",
            "runs-9-of-4.jsonl",
            "other-3-of-4.jsonl",
        ] {
            std::fs::write(dir.path().join(name), "").expect("write");
        }
        assert_eq!(Shard::found_in(dir.path(), "runs", ".jsonl"), vec![s(1, 4), s(2, 4)]);
        assert!(s(3, 4).check_count_in(dir.path(), "runs", ".jsonl").is_ok());
        let e = s(1, 1)
            .check_count_in(dir.path(), "runs", ".jsonl")
            .expect_err("refused");
        assert!(e.message.contains("--shard K/4"), "{e}");
        assert_eq!(Shard::missing(&[s(1, 4), s(3, 4), s(1, 1)]), vec![(4, vec![2, 4])]);
        assert!(Shard::missing(&[s(2, 2), s(1, 2)]).is_empty());
    }
}
