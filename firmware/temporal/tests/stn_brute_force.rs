//! The STN check against Floyd-Warshall on the distance graph, on many small random networks:
//! the same verdict (schedule or none), and the same earliest and latest times.
mod common;

use common::Rng;
use temporal::constraints::Constraint;
use temporal::stn;
use temporal::task::UNBOUNDED;

const INF: i64 = i64::MAX / 4;

/// Shortest paths on the distance graph: d[x][y] bounds t[y] - t[x] from above.
fn floyd_warshall(
    n: usize,
    cons: &[Constraint],
    windows: &[(u32, u32)],
    horizon: Option<u32>,
) -> Option<Vec<Vec<i64>>> {
    let mut d = vec![vec![INF; n]; n];
    for (i, row) in d.iter_mut().enumerate() {
        row[i] = 0;
    }
    let edge = |d: &mut Vec<Vec<i64>>, x: usize, y: usize, w: i64| d[x][y] = d[x][y].min(w);
    for c in cons {
        let (b, a) = (c.before as usize, c.after as usize);
        edge(&mut d, a, b, -i64::from(c.lb)); // t[b] - t[a] <= -lb
        if c.ub != UNBOUNDED {
            edge(&mut d, b, a, i64::from(c.ub)); // t[a] - t[b] <= ub
        }
    }
    for (k, &(lo, hi)) in windows.iter().enumerate().take(n).skip(1) {
        edge(&mut d, k, 0, -i64::from(lo)); // t[0] - t[k] <= -lo
        edge(&mut d, k, 0, 0); // every step at or after time zero
        if hi != UNBOUNDED {
            edge(&mut d, 0, k, i64::from(hi));
        }
        if let Some(h) = horizon {
            edge(&mut d, 0, k, i64::from(h));
        }
    }
    for k in 0..n {
        for i in 0..n {
            for j in 0..n {
                if d[i][k] < INF && d[k][j] < INF && d[i][k] + d[k][j] < d[i][j] {
                    d[i][j] = d[i][k] + d[k][j];
                }
            }
        }
    }
    (0..n).all(|i| d[i][i] >= 0).then_some(d)
}

fn random_network(rng: &mut Rng) -> (usize, Vec<Constraint>, Vec<(u32, u32)>) {
    let steps = 1 + rng.below(6) as usize;
    let n = steps + 1;
    let mut cons = Vec::new();
    for _ in 0..rng.below(3 * n as u64) {
        let x = rng.below(n as u64) as u16;
        let mut y = rng.below(n as u64) as u16;
        if y == x {
            y = (x + 1) % n as u16;
        }
        // Mostly forward orderings, as plans make them, some in any direction.
        let (before, after) = if x < y || rng.chance(30) {
            (x, y)
        } else {
            (y, x)
        };
        let lb = if rng.chance(50) {
            rng.below(3) as u32 * 5
        } else {
            rng.below(40) as u32
        };
        let ub = if rng.chance(60) {
            UNBOUNDED
        } else {
            lb + rng.below(30) as u32
        };
        cons.push(Constraint {
            before,
            after,
            lb,
            ub,
        });
    }
    let windows = (0..n)
        .map(|k| {
            if k == 0 || rng.chance(70) {
                (0, UNBOUNDED)
            } else {
                let lo = rng.below(50) as u32;
                (lo, lo + rng.below(60) as u32)
            }
        })
        .collect();
    (steps, cons, windows)
}

#[test]
fn earliest_times_match_floyd_warshall_on_random_networks() {
    let mut rng = Rng(0x5eed_0001);
    let (mut consistent, mut inconsistent) = (0, 0);
    for _ in 0..20_000 {
        let (steps, cons, windows) = random_network(&mut rng);
        let n = steps + 1;
        let mut est = vec![0u32; n];
        let ours = stn::earliest(steps, &cons, &|k| windows[k], &mut est);
        match floyd_warshall(n, &cons, &windows, None) {
            Some(d) => {
                assert!(
                    ours.is_ok(),
                    "{cons:?} {windows:?}: FW finds a schedule, ours says {ours:?}"
                );
                for k in 0..n {
                    assert_eq!(
                        i64::from(est[k]),
                        -d[k][0],
                        "step {k} of {cons:?} {windows:?}"
                    );
                }
                consistent += 1;
            }
            None => {
                assert!(
                    ours.is_err(),
                    "{cons:?} {windows:?}: no schedule exists, ours found {est:?}"
                );
                inconsistent += 1;
            }
        }
    }
    // Both verdicts were exercised.
    assert!(
        consistent > 2000 && inconsistent > 2000,
        "{consistent} consistent, {inconsistent} not"
    );
}

#[test]
fn latest_times_match_floyd_warshall_under_the_makespan() {
    let mut rng = Rng(0x5eed_0002);
    let mut checked = 0;
    for _ in 0..20_000 {
        let (steps, cons, windows) = random_network(&mut rng);
        let n = steps + 1;
        let mut est = vec![0u32; n];
        if stn::earliest(steps, &cons, &|k| windows[k], &mut est).is_err() {
            continue;
        }
        let horizon = est.iter().copied().max().unwrap_or(0);
        let mut lst = vec![0u32; n];
        stn::latest(steps, &cons, &|k| windows[k], horizon, &mut lst)
            .expect("consistent under its own makespan");
        let d = floyd_warshall(n, &cons, &windows, Some(horizon)).expect("consistent");
        for k in 1..n {
            assert_eq!(
                i64::from(lst[k]),
                d[0][k],
                "step {k} of {cons:?} {windows:?}"
            );
            assert!(lst[k] >= est[k]);
        }
        checked += 1;
    }
    assert!(checked > 2000);
}

#[test]
fn a_warm_start_from_a_prefix_gives_the_same_times() {
    // The search starts a child's check from its parent's earliest times.
    let mut rng = Rng(0x5eed_0003);
    for _ in 0..5_000 {
        let (steps, cons, windows) = random_network(&mut rng);
        let keep = cons.len() / 2;
        let mut warm = vec![0u32; steps + 1];
        if stn::earliest(steps, &cons[..keep], &|k| windows[k], &mut warm).is_err() {
            continue;
        }
        let mut cold = vec![0u32; steps + 1];
        let a = stn::earliest(steps, &cons, &|k| windows[k], &mut warm);
        let b = stn::earliest(steps, &cons, &|k| windows[k], &mut cold);
        assert_eq!(a.is_ok(), b.is_ok());
        if a.is_ok() {
            assert_eq!(warm, cold);
        }
    }
}

#[test]
fn an_extension_worked_out_from_the_old_times_matches_floyd_warshall() {
    // The search extends a path's network by a step's constraints, from the path's times.
    let mut rng = Rng(0x5eed_0004);
    let (mut settled, mut not_settled) = (0, 0);
    for round in 0..20_000 {
        let (steps, mut cons, windows) = random_network(&mut rng);
        if steps < 2 {
            continue;
        }
        let old_steps = 1 + rng.below(steps as u64 - 1) as usize;
        // The old network's constraints name only its steps; the new ones come after them,
        // half the time in the order the search appends them (by their later step).
        let (mut old, mut new): (Vec<_>, Vec<_>) = cons
            .drain(..)
            .partition(|c| usize::from(c.before) <= old_steps && usize::from(c.after) <= old_steps);
        if round % 2 == 0 {
            new.sort_by_key(|c| c.after);
        }
        let first = old.len();
        old.extend(new);
        let cons = old;
        let mut est = vec![0u32; steps + 1];
        if stn::earliest(old_steps, &cons[..first], &|k| windows[k], &mut est).is_err() {
            continue;
        }
        let before = est.clone();
        let get = |i: usize| cons[i];
        let ok = stn::earliest_extend(
            old_steps,
            steps,
            first,
            cons.len(),
            &get,
            &|k| windows[k],
            &mut est,
        );
        // The old steps' times are never moved by it.
        assert_eq!(est[..=old_steps], before[..=old_steps], "{cons:?}");
        let fw = floyd_warshall(steps + 1, &cons, &windows, None);
        if ok {
            let d = fw.unwrap_or_else(|| panic!("settled an inconsistent network {cons:?}"));
            for k in 0..=steps {
                assert_eq!(
                    i64::from(est[k]),
                    -d[k][0],
                    "step {k} of {cons:?} {windows:?}"
                );
            }
            settled += 1;
        } else {
            // From what it left, the whole check decides as from nothing.
            let warm = stn::earliest(steps, &cons, &|k| windows[k], &mut est);
            assert_eq!(warm.is_ok(), fw.is_some(), "{cons:?} {windows:?}");
            if let Some(d) = fw {
                for k in 0..=steps {
                    assert_eq!(i64::from(est[k]), -d[k][0], "step {k} of {cons:?}");
                }
            }
            not_settled += 1;
        }
    }
    assert!(
        settled > 1000 && not_settled > 1000,
        "{settled} settled, {not_settled} not"
    );
}
