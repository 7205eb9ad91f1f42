//! A scene's triangle budget split between its parts by error, not by size.
//!
//! A glTF scene is simplified part by part (each glTF mesh on its own, so
//! materials, nodes and skins survive). Giving every part the same ratio spends the
//! budget by size: a finely tessellated flat panel keeps as many triangles as a
//! curved handle of the same count, and the scene's largest error lands where the
//! ratio was too low for the shape. One edge-collapse queue over the whole scene
//! would instead take collapses in order of error everywhere (as Garland and
//! Heckbert's greedy order does within one mesh). This module gets the same split
//! without merging the parts: each part is simplified once as far as it goes while
//! a [`CurveRecorder`] notes, after every collapse, the triangles left and the
//! largest error so far (in scene units: the part's error times its instances'
//! stretch); [`split`] then finds the smallest error `e` at which the parts,
//! each stopped before its first collapse above `e`, fit the target, and each part
//! is simplified again to its count at `e`.

use meshlod::collapse::{CollapseRecord, Surface};
use meshlod::decimate::Observer;

/// The error curve of one part's run: where it started and, after each collapse,
/// the largest error so far and the triangles left.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Curve {
    /// Triangles before the first collapse.
    pub start: usize,
    /// `(largest error so far in scene units, triangles left)` after each
    /// collapse: the errors never fall, the counts never rise.
    pub steps: Vec<(f64, usize)>,
    /// The run told when it started (a run that never does, such as clustering,
    /// records nothing to go by).
    pub recorded: bool,
}

impl Curve {
    /// The triangles a run keeps when it stops before its first collapse whose
    /// running error is above `e`.
    #[must_use]
    pub fn count_at(&self, e: f64) -> usize {
        let n = self.steps.partition_point(|s| s.0 <= e);
        if n == 0 {
            self.start
        } else {
            self.steps[n - 1].1
        }
    }

    /// Whether the run was recorded from its start.
    #[must_use]
    pub fn recorded(&self) -> bool {
        self.recorded
    }

    /// The fewest triangles the run reached.
    #[must_use]
    pub fn floor(&self) -> usize {
        self.steps.last().map_or(self.start, |s| s.1)
    }
}

/// An observer that records a [`Curve`] and passes every call on to another.
pub struct CurveRecorder<'a> {
    inner: &'a mut dyn Observer,
    /// Scene units per part unit (the instances' largest stretch).
    scale: f64,
    triangles: usize,
    largest: f64,
    /// What was recorded.
    pub curve: Curve,
}

impl<'a> CurveRecorder<'a> {
    /// Records errors times `scale` and forwards to `inner`.
    pub fn new(inner: &'a mut dyn Observer, scale: f64) -> Self {
        Self {
            inner,
            scale,
            triangles: 0,
            largest: 0.0,
            curve: Curve::default(),
        }
    }
}

impl CurveRecorder<'_> {
    /// The observer calls are passed to (to run without recording).
    pub fn inner(&mut self) -> &mut dyn Observer {
        self.inner
    }

    /// What was recorded.
    #[must_use]
    pub fn into_curve(self) -> Curve {
        self.curve
    }
}

/// Runs `job(0..n)` on up to `threads` threads (each taking the next job when
/// done), the results in job order. After a job fails no new job starts; a
/// panicking job panics the caller.
///
/// # Errors
/// The error of the failed job first in job order.
pub fn run_parallel<T: Send>(
    n: usize,
    threads: usize,
    job: impl Fn(usize) -> anyhow::Result<T> + Sync,
) -> anyhow::Result<Vec<T>> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    use std::sync::Mutex;
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let slots: Vec<Mutex<Option<anyhow::Result<T>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, n.max(1)) {
            s.spawn(|| loop {
                if failed.load(Ordering::Relaxed) {
                    break;
                }
                let j = next.fetch_add(1, Ordering::Relaxed);
                if j >= n {
                    break;
                }
                let r = job(j);
                if r.is_err() {
                    failed.store(true, Ordering::Relaxed);
                }
                if let Ok(mut slot) = slots[j].lock() {
                    *slot = Some(r);
                }
            });
        }
    });
    let mut out = Vec::with_capacity(n);
    for m in slots {
        match m.into_inner().ok().flatten() {
            Some(r) => out.push(r?),
            // Not started: a job before it failed, whose error comes first
            // unless an earlier one's does.
            None => continue,
        }
    }
    if out.len() < n {
        // Unreachable without a failure, which `?` returned above.
        anyhow::bail!("{} of {n} parts did not run", n - out.len());
    }
    Ok(out)
}

impl Observer for CurveRecorder<'_> {
    fn started(&mut self, triangles: usize, target: usize) {
        // A run that starts again (a retry) starts a new curve.
        self.triangles = triangles;
        self.largest = 0.0;
        self.curve = Curve {
            start: triangles,
            steps: Vec::new(),
            recorded: true,
        };
        self.inner.started(triangles, target);
    }
    fn before_collapse(&mut self, surface: &Surface, removed: u32, kept: u32) {
        self.inner.before_collapse(surface, removed, kept);
    }
    fn collapsed(&mut self, record: &CollapseRecord) {
        self.triangles = self.triangles.saturating_sub(record.removed_count as usize);
        let e = record.error * self.scale;
        if e > self.largest {
            self.largest = e;
        }
        self.curve.steps.push((self.largest, self.triangles));
        self.inner.collapsed(record);
    }
    fn progress(&mut self, triangles: usize) {
        // Triangles can also go without a collapse (a separate part removed
        // whole): the count follows, at the error reached so far.
        if self.curve.recorded && triangles < self.triangles {
            self.triangles = triangles;
            self.curve.steps.push((self.largest, triangles));
        }
        self.inner.progress(triangles);
    }
}

/// The smallest error (scene units; `-∞` when nothing need go) at which the
/// scene fits `want` triangles, a part drawn `instances[i]` times counting that
/// many times, and each part's triangle count there; `None` when even every part's
/// floor does not fit.
#[must_use]
pub fn split(curves: &[Curve], instances: &[usize], want: usize) -> Option<(f64, Vec<usize>)> {
    let total = |e: f64| -> usize {
        curves
            .iter()
            .zip(instances)
            .map(|(c, &k)| c.count_at(e) * k)
            .sum()
    };
    let floor: usize = curves
        .iter()
        .zip(instances)
        .map(|(c, &k)| c.floor() * k)
        .sum();
    if floor > want {
        return None;
    }
    let mut errors: Vec<f64> = curves
        .iter()
        .flat_map(|c| c.steps.iter().map(|s| s.0))
        .collect();
    errors.sort_by(f64::total_cmp);
    errors.dedup();
    // The scene's count falls as `e` grows: the first error at which it fits.
    if total(f64::NEG_INFINITY) <= want {
        let e = f64::NEG_INFINITY;
        return Some((e, curves.iter().map(|c| c.count_at(e)).collect()));
    }
    let i = errors.partition_point(|&e| total(e) > want);
    let e = errors.get(i).copied().unwrap_or(f64::INFINITY);
    let mut counts: Vec<usize> = curves.iter().map(|c| c.count_at(e)).collect();
    // A running maximum holds over many collapses, so the step to `e` can drop
    // far below `want`: the parts whose run reached `e` there stop partway
    // through that stretch instead (every collapse in it is at most `e`).
    let before = if i == 0 {
        f64::NEG_INFINITY
    } else {
        errors[i - 1]
    };
    // The room left goes to the parts in index order (deterministic; a part
    // earlier in the scene keeps the few extra triangles).
    let mut slack = want - total(e);
    for ((c, n), &k) in curves.iter().zip(&mut counts).zip(instances) {
        if slack == 0 {
            break;
        }
        if k == 0 {
            continue;
        }
        let cap = *n + (c.count_at(before) - *n).min(slack / k);
        // The largest count at most `cap` that the run passes through.
        let m = if c.start <= cap {
            c.start
        } else {
            let j = c.steps.partition_point(|s| s.1 > cap);
            c.steps.get(j).map_or(*n, |s| s.1)
        };
        slack -= (m - *n) * k;
        *n = m;
    }
    Some((e, counts))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(start: usize, steps: &[(f64, usize)]) -> Curve {
        Curve {
            start,
            steps: steps.to_vec(),
            recorded: true,
        }
    }

    #[test]
    fn count_at_stops_before_the_first_larger_error() {
        let c = curve(10, &[(0.1, 8), (0.1, 6), (0.5, 4), (0.9, 2)]);
        assert_eq!(c.count_at(0.05), 10);
        assert_eq!(c.count_at(0.1), 6);
        assert_eq!(c.count_at(0.7), 4);
        assert_eq!(c.count_at(5.0), 2);
        assert_eq!(c.floor(), 2);
    }

    /// A flat part (its collapses cost nothing until 2 triangles) and a curved one
    /// (errors from the first collapse): the flat part gives its triangles first,
    /// where a split by size would take 90% from each.
    #[test]
    fn the_cheap_part_gives_first() {
        let flat = curve(100, &[(0.0, 98), (0.0, 50), (0.0, 2)]);
        let round = curve(
            100,
            &[(0.2, 98), (0.3, 90), (0.4, 60), (0.6, 30), (1.0, 20)],
        );
        let (e, counts) = split(&[flat.clone(), round.clone()], &[1, 1], 92).unwrap();
        assert_eq!((e, counts), (0.3, vec![2, 90]));
        // Drawn three times, the round part's collapses count three times over.
        let (e, counts) = split(&[flat, round], &[1, 3], 200).unwrap();
        assert_eq!((e, counts), (0.4, vec![2, 60]));
    }

    /// The running maximum holds from 80 down to 20 triangles: the part stops
    /// partway through that stretch, at the count the target leaves it.
    #[test]
    fn a_part_stops_inside_a_stretch_of_one_error() {
        let mut steps = vec![(0.1, 98), (0.5, 96), (0.5, 94), (0.9, 80)];
        steps.extend((0..30).map(|k| (0.9, 78 - 2 * k)));
        let c = curve(100, &steps);
        let other = curve(10, &[(0.05, 8)]);
        let (e, counts) = split(&[c.clone(), other.clone()], &[1, 1], 58).unwrap();
        assert_eq!((e, counts), (0.9, vec![50, 8]));
        // Drawn twice, it may only take back whole pairs of triangles.
        let (e, counts) = split(&[other, c], &[1, 2], 108).unwrap();
        assert_eq!((e, counts), (0.9, vec![8, 50]));
    }

    #[test]
    fn jobs_come_back_in_order_and_the_first_failure_is_reported() {
        for threads in [1, 2, 5] {
            let squares = run_parallel(7, threads, |j| Ok(j * j)).unwrap();
            assert_eq!(squares, vec![0, 1, 4, 9, 16, 25, 36], "{threads} threads");
            let failed = run_parallel(7, threads, |j| {
                if j >= 3 {
                    anyhow::bail!("job {j} failed")
                }
                Ok(j)
            });
            assert_eq!(failed.unwrap_err().to_string(), "job 3 failed");
        }
        assert!(run_parallel(0, 2, Ok).unwrap().is_empty());
    }

    /// Collapses and removals without a collapse (a part removed whole) both
    /// count; a recorder whose run never started records nothing to go by.
    #[test]
    fn the_recorder_follows_collapses_and_removals() {
        let mut none = meshlod::decimate::NoObserver;
        let mut rec = CurveRecorder::new(&mut none, 2.0);
        rec.progress(5);
        assert!(!rec.curve.recorded());
        rec.started(10, 0);
        rec.collapsed(&CollapseRecord {
            removed: 1,
            kept: 0,
            removed_position: [0.0; 3],
            kept_old_position: [0.0; 3],
            position: [0.0; 3],
            removed_triangles: [0, 1],
            removed_count: 2,
            apexes: [2, 3],
            non_edge: false,
            closed_hole: meshlod::collapse::DEAD,
            cost: 0.0,
            error: 0.25,
        });
        rec.progress(4);
        let c = rec.into_curve();
        assert!(c.recorded());
        assert_eq!(c.steps, vec![(0.5, 8), (0.5, 4)]);
        assert_eq!(c.floor(), 4);
    }

    #[test]
    fn nothing_to_give_or_not_enough() {
        let a = curve(10, &[(0.1, 8), (0.2, 6)]);
        let b = curve(10, &[(0.3, 8)]);
        let nothing = split(&[a.clone(), b.clone()], &[1, 1], 20);
        assert_eq!(nothing, Some((f64::NEG_INFINITY, vec![10, 10])));
        assert_eq!(split(&[a.clone(), b.clone()], &[1, 1], 13), None);
        assert_eq!(
            split(&[a.clone(), b.clone()], &[1, 1], 14),
            Some((0.3, vec![6, 8]))
        );
        assert_eq!(split(&[a, b], &[1, 1], 17), Some((0.2, vec![6, 10])));
    }
}
