//! The spread rule's check run by a caller as it moves the points
//! ([`NeighborList::spread_watch`], [`NeighborList::update_seen`]).
//!
//! Why: the list's own check walks every point once or three times a step (from zero, then
//! the displacements' bounding box, then from its centre), each walk a fork and a join on
//! the pool. A mover that already touches each point sees its displacement from zero and
//! from a guessed centre, and the box, in the same pass. The rule holds for any centre c
//! (two points have approached each other by at most |Δ_i − c| + |Δ_j − c|), so a list is
//! kept whenever either of the two seen is within half the skin; only when both are beyond
//! does the list walk its points once more, from the box's centre, as its own check would.
//! So it never rebuilds where its own check would not, and the steps between builds need
//! no walk of their own.

use nalgebra::SVector;

use super::{Bounds, NeighborList, Rebuild};

/// A spread-rule list's rebuild check of single points: each point's displacement since
/// the build, from zero and from a guess of the displacements' centre (the last two steps'
/// box centres extrapolated: a bed falling steadily moves its centre by the same each step).
#[derive(Debug, Clone, Copy)]
pub struct SpreadWatch<'a, const D: usize> {
    reference: &'a [SVector<f64, D>],
    guess: SVector<f64, D>,
}

impl<const D: usize> SpreadWatch<'_, D> {
    /// Adds what the watch sees of point i at `p` to `seen` (in place, by comparisons
    /// alone: a mover's pass stays a plain loop).
    pub fn see(&self, seen: &mut Spread<D>, i: usize, p: &SVector<f64, D>) {
        let moved = p - self.reference[i];
        let (still, guessed) = (moved.norm_squared(), (moved - self.guess).norm_squared());
        seen.still = if still > seen.still {
            still
        } else {
            seen.still
        };
        seen.guessed = if guessed > seen.guessed {
            guessed
        } else {
            seen.guessed
        };
        for k in 0..D {
            let (lo, hi) = (&mut seen.bounds.0[k], &mut seen.bounds.1[k]);
            *lo = if moved[k] < *lo { moved[k] } else { *lo };
            *hi = if moved[k] > *hi { moved[k] } else { *hi };
        }
    }
}

/// What a spread watch saw of some points: the largest squared displacement from zero and
/// from the guessed centre, and the displacements' bounding box. Merged by maxima and
/// minima, so the same in any order.
#[derive(Debug, Clone, Copy)]
pub struct Spread<const D: usize> {
    still: f64,
    guessed: f64,
    bounds: Bounds<D>,
}

impl<const D: usize> Spread<D> {
    /// Nothing seen.
    pub fn none() -> Self {
        let far = SVector::repeat(f64::INFINITY);
        Self {
            still: 0.0,
            guessed: 0.0,
            bounds: (far, -far),
        }
    }

    /// What both saw.
    pub fn merge(self, other: Self) -> Self {
        Self {
            still: self.still.max(other.still),
            guessed: self.guessed.max(other.guessed),
            bounds: (
                self.bounds.0.inf(&other.bounds.0),
                self.bounds.1.sup(&other.bounds.1),
            ),
        }
    }
}

impl<const D: usize> NeighborList<D> {
    /// The spread rule's check for a caller that moves the `n` points and runs it over every
    /// point as it moves them ([`Self::update_seen`]); None for a list rebuilt on a distance
    /// or not built for `n` points.
    pub fn spread_watch(&self, n: usize) -> Option<SpreadWatch<'_, D>> {
        match self.rule {
            Rebuild::Spread if self.reference.len() == n => Some(SpreadWatch {
                reference: &self.reference,
                guess: 2.0 * self.centres[0] - self.centres[1],
            }),
            _ => None,
        }
    }

    /// [`Self::update`] for a caller that ran [`Self::spread_watch`] over every point as it
    /// moved them to `positions`, and saw `seen`. Rebuilds if needed; returns whether it did.
    pub fn update_seen(
        &mut self,
        positions: &[SVector<f64, D>],
        radii: &[f64],
        seen: Spread<D>,
    ) -> bool {
        debug_assert!(self.spread_watch(positions.len()).is_some());
        let limit2 = (0.5 * self.skin).powi(2);
        let centre = 0.5 * (seen.bounds.0 + seen.bounds.1);
        let rebuild =
            seen.still > limit2 && seen.guessed > limit2 && self.beyond(positions, centre);
        if rebuild {
            self.build(positions, radii);
        } else {
            self.centres = [centre, self.centres[0]];
        }
        rebuild
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;
    use rand::{RngExt, SeedableRng};

    /// A bed of points settling onto a floor (the lower ones slowing, all jostled), moved and
    /// watched: the watched list rebuilds no more often than the list's own check, never
    /// misses a pair within R_i + R_j.
    #[test]
    fn a_watched_spread_list_misses_no_pair_and_rebuilds_no_sooner() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let n = 300;
        let mut positions: Vec<Vector3<f64>> = (0..n)
            .map(|_| Vector3::from_fn(|_, _| rng.random::<f64>() * 9.0))
            .collect();
        let radii: Vec<f64> = (0..n).map(|_| 0.4 + 0.2 * rng.random::<f64>()).collect();
        let (mut own, mut watched) = (
            NeighborList::<3>::rebuilt_on_spread(0.3),
            NeighborList::<3>::rebuilt_on_spread(0.3),
        );
        assert!(watched.spread_watch(n).is_none(), "no watch before a build");
        own.update(&positions, &radii);
        watched.update(&positions, &radii);
        for _ in 0..300 {
            let watch = watched
                .spread_watch(n)
                .expect("a built spread list has a watch");
            let mut seen = Spread::none();
            for (i, p) in positions.iter_mut().enumerate() {
                let fall = 0.02 * (p.z / 9.0).clamp(0.2, 1.0);
                *p += Vector3::from_fn(|_, _| 0.004 * (rng.random::<f64>() - 0.5));
                p.z -= fall;
                watch.see(&mut seen, i, p);
            }
            watched.update_seen(&positions, &radii, seen);
            own.update(&positions, &radii);
            for i in 0..n {
                for j in (0..n).filter(|&j| j != i) {
                    if (positions[j] - positions[i]).norm() < radii[i] + radii[j] {
                        assert!(watched.of(i).contains(&(j as u32)), "{i}–{j} missed");
                    }
                }
            }
        }
        assert!(
            own.builds() > 5,
            "the moves rebuilt the list: {}",
            own.builds()
        );
        assert!(
            watched.builds() <= own.builds(),
            "{} {}",
            watched.builds(),
            own.builds()
        );
        assert!(NeighborList::<3>::new(0.3).spread_watch(0).is_none());
    }

    /// Points moving as one: the guessed centre follows them, and the list is never rebuilt.
    #[test]
    fn a_watched_translation_never_rebuilds() {
        let positions = vec![Vector3::zeros(), Vector3::new(3.0, 0.0, 0.0)];
        let radii = vec![1.0, 1.0];
        let mut list = NeighborList::<3>::rebuilt_on_spread(0.4);
        list.update(&positions, &radii);
        for step in 1..50 {
            let moved: Vec<_> = positions
                .iter()
                .map(|p| p + Vector3::new(0.1, -0.2, 0.05) * f64::from(step))
                .collect();
            let watch = list.spread_watch(2).unwrap();
            let mut seen = Spread::none();
            (0..2).for_each(|i| watch.see(&mut seen, i, &moved[i]));
            assert!(!list.update_seen(&moved, &radii, seen), "step {step}");
        }
        assert_eq!(list.builds(), 1);
    }
}
