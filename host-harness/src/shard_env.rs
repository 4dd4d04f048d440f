//! Shards from the environment of the batch engines users already run (issue 12 item 6), for
//! `hil study` and `hil campaign` when `--shard` is not given:
//! - GitLab parallel jobs: `CI_NODE_INDEX` (1-based) / `CI_NODE_TOTAL`;
//! - Slurm job arrays: `SLURM_ARRAY_TASK_ID` / `SLURM_ARRAY_TASK_COUNT`, with the array's
//!   first index `SLURM_ARRAY_TASK_MIN` (default 0) subtracted, so `--array=0-3` and
//!   `--array=1-4` both give shards 1/4..4/4;
//! - Kubernetes Indexed Jobs: `JOB_COMPLETION_INDEX` (0-based) and the completions count,
//!   which Kubernetes does not put in the environment: set `JOB_COMPLETIONS` to the Job's
//!   `spec.completions` (the shipped manifest does).
//!
//! A pure function of a map of variables ([`shard_from_vars`]), so the tests need not touch
//! the process environment.
use std::collections::BTreeMap;

use crate::campaign::Shard;

/// The shard the variables name, and which engine's they are; None when none is set. An
/// engine's variables that are set but wrong (missing partner, not a number, out of range)
/// are an error naming them.
pub fn shard_from_vars(
    vars: &BTreeMap<String, String>,
) -> Result<Option<(Shard, &'static str)>, String> {
    let get = |k: &str| vars.get(k).map(|v| v.trim()).filter(|v| !v.is_empty());
    let num = |k: &str| -> Result<u32, String> {
        let v = get(k).ok_or_else(|| format!("{k} is not set"))?;
        v.parse()
            .map_err(|_| format!("{k}={v:?} is not a non-negative integer"))
    };
    let make = |k: u32, n: u32, engine: &'static str, names: &str| {
        if n == 0 || k == 0 || k > n {
            Err(format!(
                "{names} give shard {k}/{n}: expected 1 <= index <= count"
            ))
        } else {
            Ok(Some((Shard { k, n }, engine)))
        }
    };
    if get("CI_NODE_INDEX").is_some() || get("CI_NODE_TOTAL").is_some() {
        let (i, n) = (num("CI_NODE_INDEX")?, num("CI_NODE_TOTAL")?);
        return make(i, n, "GitLab", "CI_NODE_INDEX/CI_NODE_TOTAL");
    }
    if get("SLURM_ARRAY_TASK_ID").is_some() {
        let id = num("SLURM_ARRAY_TASK_ID")?;
        let n = num("SLURM_ARRAY_TASK_COUNT")?;
        let min = if get("SLURM_ARRAY_TASK_MIN").is_some() {
            num("SLURM_ARRAY_TASK_MIN")?
        } else {
            0
        };
        let k = id.checked_sub(min).ok_or_else(|| {
            format!("SLURM_ARRAY_TASK_ID={id} is below SLURM_ARRAY_TASK_MIN={min}")
        })?;
        return make(
            k + 1,
            n,
            "Slurm",
            "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT",
        );
    }
    if get("JOB_COMPLETION_INDEX").is_some() {
        let i = num("JOB_COMPLETION_INDEX")?;
        let n = num("JOB_COMPLETIONS").map_err(|e| {
            format!("{e}: a Kubernetes Indexed Job sets JOB_COMPLETION_INDEX but not the completions count; set JOB_COMPLETIONS to spec.completions")
        })?;
        return make(
            i + 1,
            n,
            "Kubernetes",
            "JOB_COMPLETION_INDEX/JOB_COMPLETIONS",
        );
    }
    Ok(None)
}

/// The variables of this process that [`shard_from_vars`] reads.
pub fn process_vars() -> BTreeMap<String, String> {
    [
        "CI_NODE_INDEX",
        "CI_NODE_TOTAL",
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_ARRAY_TASK_MIN",
        "JOB_COMPLETION_INDEX",
        "JOB_COMPLETIONS",
    ]
    .iter()
    .filter_map(|k| std::env::var(k).ok().map(|v| (k.to_string(), v)))
    .collect()
}

/// `--shard` if given, else the environment's; prints which engine's it took.
pub fn resolve(
    flag: Option<&str>,
    vars: &BTreeMap<String, String>,
) -> Result<Option<Shard>, String> {
    if let Some(text) = flag {
        return Shard::parse(text).map(Some);
    }
    Ok(shard_from_vars(vars)?.map(|(s, engine)| {
        println!("  shard {s} from the {engine} environment");
        s
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vars(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    fn shard(pairs: &[(&str, &str)]) -> Option<(u32, u32, &'static str)> {
        shard_from_vars(&vars(pairs))
            .unwrap()
            .map(|(s, e)| (s.k, s.n, e))
    }

    #[test]
    fn gitlab_is_one_based() {
        assert_eq!(
            shard(&[("CI_NODE_INDEX", "1"), ("CI_NODE_TOTAL", "4")]),
            Some((1, 4, "GitLab"))
        );
        assert_eq!(
            shard(&[("CI_NODE_INDEX", "4"), ("CI_NODE_TOTAL", "4")]),
            Some((4, 4, "GitLab"))
        );
        assert!(shard_from_vars(&vars(&[("CI_NODE_INDEX", "0"), ("CI_NODE_TOTAL", "4")])).is_err());
        assert!(shard_from_vars(&vars(&[("CI_NODE_INDEX", "2")])).is_err());
    }

    #[test]
    fn slurm_counts_from_the_arrays_first_index() {
        assert_eq!(
            shard(&[
                ("SLURM_ARRAY_TASK_ID", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "3")
            ]),
            Some((1, 3, "Slurm"))
        );
        assert_eq!(
            shard(&[
                ("SLURM_ARRAY_TASK_ID", "3"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
                ("SLURM_ARRAY_TASK_MIN", "1")
            ]),
            Some((3, 3, "Slurm"))
        );
        assert!(shard_from_vars(&vars(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "3")
        ]))
        .is_err());
        assert!(shard_from_vars(&vars(&[("SLURM_ARRAY_TASK_ID", "x")])).is_err());
    }

    #[test]
    fn kubernetes_needs_the_completions_count() {
        assert_eq!(
            shard(&[("JOB_COMPLETION_INDEX", "0"), ("JOB_COMPLETIONS", "5")]),
            Some((1, 5, "Kubernetes"))
        );
        assert_eq!(
            shard(&[("JOB_COMPLETION_INDEX", "4"), ("JOB_COMPLETIONS", "5")]),
            Some((5, 5, "Kubernetes"))
        );
        let e = shard_from_vars(&vars(&[("JOB_COMPLETION_INDEX", "0")])).unwrap_err();
        assert!(e.contains("JOB_COMPLETIONS"), "{e}");
    }

    #[test]
    fn nothing_set_is_no_shard_and_the_flag_wins() {
        assert_eq!(shard(&[("HOME", "/root")]), None);
        let v = vars(&[("CI_NODE_INDEX", "1"), ("CI_NODE_TOTAL", "2")]);
        assert_eq!(
            resolve(Some("2/3"), &v).unwrap(),
            Some(Shard { k: 2, n: 3 })
        );
        assert_eq!(resolve(None, &v).unwrap(), Some(Shard { k: 1, n: 2 }));
    }
}
