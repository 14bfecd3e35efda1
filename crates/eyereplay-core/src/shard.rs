//! Which part of a dataset this process renders.
//!
//! Sessions are numbered in `labels.csv` order; session `i` belongs to shard
//! `i mod N`. Round-robin rather than contiguous blocks, so every shard gets
//! both classes and about the same work.

use crate::CoreError as Error;

type Result<T> = std::result::Result<T, Error>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// 0-based.
    pub index: usize,
    pub count: usize,
}

/// A shard error of values that came from the environment, saying which
/// variables gave them (no `--shard` was given to look for).
fn from_env(e: Error, source: &str) -> Error {
    match e {
        Error::Setting(m) => Error::Setting(format!("{m}, from {source}")),
        other => other,
    }
}

impl Shard {
    pub fn new(index: usize, count: usize) -> Result<Self> {
        if count == 0 {
            return Err(Error::Setting("shard count must be at least 1".into()));
        }
        if index >= count {
            return Err(Error::Setting(format!(
                "shard index {index} is out of range for {count} shards (indices are 0-based)"
            )));
        }
        Ok(Shard { index, count })
    }

    /// `K/N`.
    pub fn parse(s: &str) -> Result<Self> {
        let (k, n) = parse_usize_pair("--shard", s, &['/'], "K/N, e.g. 0/4", ["K", "N"])?;
        Shard::new(k, n)
    }

    /// [`Shard::resolve_with`] on this process's environment.
    pub fn resolve(flag: Option<&str>, shards: Option<usize>) -> Result<Option<Self>> {
        Self::resolve_with(flag, shards, |k| std::env::var(k).ok())
    }

    /// `--shard` first; else Slurm's array variables; else Kubernetes'
    /// `JOB_COMPLETION_INDEX`. `shards` (`--shards` / `EYEREPLAY_SHARDS`)
    /// is the total count: with Slurm it makes the task id itself the
    /// shard index (a rerun of some shards, `--array=2,5`), as
    /// `docs/cluster/slurm-array.sbatch` reads it; with `--shard K/N` it
    /// must agree with N; with no index at all it is an error, not
    /// ignored (every such process would render the whole dataset).
    pub fn resolve_with(
        flag: Option<&str>,
        shards: Option<usize>,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<Self>> {
        if let Some(f) = flag {
            let shard = Shard::parse(f)?;
            return match shards {
                Some(n) if n != shard.count => Err(Error::Setting(format!(
                    "--shard {f} and --shards {n} (or EYEREPLAY_SHARDS) disagree on the shard count"
                ))),
                _ => Ok(Some(shard)),
            };
        }
        let num = |k: &str| -> Result<Option<usize>> {
            match env(k) {
                None => Ok(None),
                Some(v) => v
                    .trim()
                    .parse()
                    .map(Some)
                    .map_err(|_| Error::Setting(format!("{k}='{v}' is not a number"))),
            }
        };
        if let Some(k) = num("SLURM_ARRAY_TASK_ID")? {
            if let Some(n) = shards {
                return Shard::new(k, n).map(Some).map_err(|e| {
                    from_env(e, "SLURM_ARRAY_TASK_ID and --shards (or EYEREPLAY_SHARDS)")
                });
            }
            let n = num("SLURM_ARRAY_TASK_COUNT")?.ok_or_else(|| {
                Error::Setting(
                    "SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not: set EYEREPLAY_SHARDS to the shard count".into(),
                )
            })?;
            // Arrays may start at a nonzero id (--array=1-4); one with
            // holes (--array=2,5) does not say the shard count.
            let min = num("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let max = num("SLURM_ARRAY_TASK_MAX")?.unwrap_or(min + n.saturating_sub(1));
            if max + 1 != min + n {
                return Err(Error::Setting(format!(
                    "the Slurm array {min}-{max} has {n} tasks, not a contiguous range: set EYEREPLAY_SHARDS to the shard count (the task id is then the shard index)"
                )));
            }
            return Shard::new(
                k.checked_sub(min).ok_or_else(|| {
                    Error::Setting("SLURM_ARRAY_TASK_ID below SLURM_ARRAY_TASK_MIN".into())
                })?,
                n,
            )
            .map(Some)
            .map_err(|e| {
                from_env(
                    e,
                    "SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN and SLURM_ARRAY_TASK_COUNT",
                )
            });
        }
        if let Some(k) = num("JOB_COMPLETION_INDEX")? {
            let n = shards.ok_or_else(|| {
                Error::Setting("JOB_COMPLETION_INDEX is set: give the shard count with --shards N or EYEREPLAY_SHARDS".into())
            })?;
            return Shard::new(k, n).map(Some).map_err(|e| {
                from_env(e, "JOB_COMPLETION_INDEX and --shards (or EYEREPLAY_SHARDS)")
            });
        }
        match shards {
            Some(n) => Err(Error::Setting(format!(
                "--shards {n} (or EYEREPLAY_SHARDS) gives the shard count, but nothing gives this process's shard: use --shard K/{n}, or run it as a Slurm array task or a Kubernetes Indexed Job"
            ))),
            None => Ok(None),
        }
    }

    pub fn contains(&self, session_ordinal: usize) -> bool {
        session_ordinal % self.count == self.index
    }

    /// Sessions of `total` in this shard.
    pub fn count_of(&self, total: usize) -> usize {
        (0..total).filter(|i| self.contains(*i)).count()
    }
}

/// Two numbers joined by one of `seps`, as in `--shard 0/4` or `--size
/// 1280x720`; errors name the flag, the value and the expected form.
pub fn parse_usize_pair(
    flag: &str,
    s: &str,
    seps: &[char],
    form: &str,
    names: [&str; 2],
) -> Result<(usize, usize)> {
    let (a, b) = s
        .split_once(seps)
        .ok_or_else(|| Error::Setting(format!("{flag} '{s}': expected {form}")))?;
    let num = |v: &str, name: &str| -> Result<usize> {
        v.trim()
            .parse()
            .map_err(|_| Error::Setting(format!("{flag} '{s}': {name} is not a number")))
    };
    Ok((num(a, names[0])?, num(b, names[1])?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| {
            pairs
                .iter()
                .find(|(a, _)| *a == k)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn parse_and_partition() {
        let s = Shard::parse("2/4").unwrap();
        let mine: Vec<usize> = (0..10).filter(|i| s.contains(*i)).collect();
        assert_eq!(mine, vec![2, 6]);
        assert_eq!(s.count_of(10), 2);
        // Every session lands in exactly one shard.
        for i in 0..37 {
            assert_eq!(
                (0..4)
                    .filter(|k| Shard::new(*k, 4).unwrap().contains(i))
                    .count(),
                1
            );
        }
        assert!(Shard::parse("4/4")
            .unwrap_err()
            .to_string()
            .contains("0-based"));
        assert!(Shard::parse("x").is_err());
    }

    #[test]
    fn engines_indices() {
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert_eq!(
            Shard::resolve_with(None, None, slurm).unwrap(),
            Some(Shard { index: 3, count: 4 })
        );
        let slurm1 = env(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
        ]);
        assert_eq!(
            Shard::resolve_with(None, None, slurm1).unwrap(),
            Some(Shard { index: 3, count: 4 })
        );
        let k8s = env(&[("JOB_COMPLETION_INDEX", "5")]);
        assert_eq!(
            Shard::resolve_with(None, Some(8), &k8s).unwrap(),
            Some(Shard { index: 5, count: 8 })
        );
        assert!(Shard::resolve_with(None, None, &k8s)
            .unwrap_err()
            .to_string()
            .contains("--shards"));
        // An index past the count names the variables it came from.
        let past = env(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
        ]);
        let e = Shard::resolve_with(None, None, past)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("out of range for 2 shards") && e.contains("from SLURM_ARRAY_TASK_ID"),
            "{e}"
        );
        let e = Shard::resolve_with(None, Some(4), &k8s)
            .unwrap_err()
            .to_string();
        assert!(e.contains("from JOB_COMPLETION_INDEX"), "{e}");
        // The flag wins over the environment.
        let both = env(&[
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
        ]);
        assert_eq!(
            Shard::resolve_with(Some("0/3"), None, both).unwrap(),
            Some(Shard { index: 0, count: 3 })
        );
        assert_eq!(Shard::resolve_with(None, None, env(&[])).unwrap(), None);
    }

    #[test]
    fn the_shard_count_agrees_with_the_index_or_is_refused() {
        fn err(
            flag: Option<&str>,
            shards: Option<usize>,
            e: impl Fn(&str) -> Option<String>,
        ) -> String {
            Shard::resolve_with(flag, shards, e)
                .unwrap_err()
                .to_string()
        }
        // The flag and the count: the same N, or an error naming both.
        assert_eq!(
            Shard::resolve_with(Some("5/8"), Some(8), env(&[])).unwrap(),
            Some(Shard { index: 5, count: 8 })
        );
        assert!(err(Some("5/8"), Some(4), env(&[])).contains("--shard 5/8 and --shards 4"));
        // A count and no index: every process would render everything.
        assert!(err(None, Some(4), env(&[])).contains("--shard K/4"));
        // A Slurm rerun of shards 2 and 5 of 24 (--array=2,5): the task id
        // is the shard, the count EYEREPLAY_SHARDS, not the array's 2 tasks.
        let rerun = env(&[
            ("SLURM_ARRAY_TASK_ID", "5"),
            ("SLURM_ARRAY_TASK_COUNT", "2"),
            ("SLURM_ARRAY_TASK_MIN", "2"),
            ("SLURM_ARRAY_TASK_MAX", "5"),
        ]);
        assert_eq!(
            Shard::resolve_with(None, Some(24), &rerun).unwrap(),
            Some(Shard {
                index: 5,
                count: 24
            })
        );
        // Without the count, that array cannot say which shard task 5 is.
        assert!(err(None, None, &rerun).contains("not a contiguous range"));
    }
}
