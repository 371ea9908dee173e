//! Total force and moment on every particle of the interacting model: Lorentz and drag plus
//! the pair forces, gathered per particle (each particle sums its partners in ascending
//! order), so the result is bit-identical at any thread count. Contacts come from the shared
//! Verlet list; the near field is summed over all pairs (exact, by the kernel of
//! [`AllPairs`] for the source's exponents), within a cut-off, or by a Barnes–Hut tree.

use std::time::Instant;

use nalgebra::Vector3;
use rayon::prelude::*;

use super::all_pairs::AllPairs;
use super::bonds::BondIndex;
use super::cloud::Cloud;
use super::field::{lorentz_acceleration, Drag};
use super::pairs::{clearly_beyond, contact_area, Body, PairLaw};
use super::params::{BlastParams, NearFieldPrecision};
use super::tree::Octree;
use crate::neighbor::NeighborList;

/// Particles per rayon task: enough work to amortize scheduling.
const CHUNK: usize = 32;

/// The contact list's skin in particle radii: pairs within 2R + skin are listed, and the
/// list is rebuilt once a particle has moved half of it. Why 0.3: in the collapsed cloud
/// nearly every listed partner within the skin is an unbonded non-contact that the force
/// gather visits at every evaluation, and a thinner shell holds fewer of them; 0.3 R ran
/// the interacting example 1.03–1.14× faster than 0.5 R on 1 thread (five pairs,
/// results/bench/README.md), with the same bits (only touching pairs act).
const CONTACT_SKIN: f64 = 0.3;

/// Wall-clock time each stage of the force evaluations has taken so far, s: where a run's
/// time goes, on any number of threads (`magopt bench blast` prints it). Why: the stages scale
/// differently with the thread count, and which one keeps a run from scaling shows here
/// without a profiler (results/bench/README.md, "`blast` on two threads, stage by stage").
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Contact-list checks and rebuilds, each with every particle's unbonded contacts.
    pub contacts: f64,
    /// The near field: its cut-off list, its tree or its all-pairs sum.
    pub near_field: f64,
    /// The bonded pairs' wrenches.
    pub bonds: f64,
    /// Each particle's force and moment gathered from its contacts, bonds and near field.
    pub gather: f64,
    /// New bonds found and added after each accepted step (with its contact-list check).
    pub bond_formation: f64,
}

impl StageTimes {
    /// The stages with their names, in the order the evaluation runs them.
    pub fn named(&self) -> [(&'static str, f64); 5] {
        [
            ("contacts", self.contacts),
            ("near_field", self.near_field),
            ("bonds", self.bonds),
            ("gather", self.gather),
            ("bond_formation", self.bond_formation),
        ]
    }
}

/// Adds the time since `mark` to `stage` and moves the mark to now.
fn lap(stage: &mut f64, mark: &mut Instant) {
    let now = Instant::now();
    *stage += (now - *mark).as_secs_f64();
    *mark = now;
}

/// Forces, bonds and neighbour lists of the interacting model.
#[derive(Debug, Clone)]
pub struct Interactor {
    law: PairLaw,
    drag: Drag,
    field: Vector3<f64>,
    electric_field: Vector3<f64>,
    contacts: NeighborList<3>,
    near: Option<(NeighborList<3>, f64)>,
    /// Barnes–Hut tree and opening angle (θ > 0 only).
    tree: Option<(Octree, f64)>,
    /// The exact all-pairs kernel (no cut-off, no tree, β = (1, 2) only).
    all_pairs: Option<AllPairs>,
    /// Near-field forces from the tree or the all-pairs kernel, per particle, N.
    near_forces: Vec<Vector3<f64>>,
    /// Scratch of `form_bonds`: each particle's new partners and contact areas, ascending.
    fresh: Vec<Vec<(u32, f64)>>,
    /// Each particle's contact-list partners that are not bonded to it, ascending: kept
    /// with the list and the bonds, so the force and bond searches skip no bonded partner.
    unbonded: Vec<Vec<u32>>,
    /// Each particle's bonds, and the bonded pairs once each with their wrenches.
    bond_index: BondIndex,
    radii: Vec<f64>,
    near_radii: Vec<f64>,
    /// Time spent in each stage so far.
    times: StageTimes,
}

impl Interactor {
    /// The interactions of `params` for `n` particles.
    pub fn new(params: &BlastParams, n: usize) -> Self {
        let cutoff = params.near_field.cutoff;
        let near_field = params.interactions.near_field;
        let near = (near_field && cutoff > 0.0).then(|| (NeighborList::new(0.1 * cutoff), cutoff));
        let theta = params.near_field.theta;
        let law = PairLaw::new(params);
        let all_pairs = (near_field && cutoff <= 0.0 && theta <= 0.0 && AllPairs::applies(&law))
            .then(|| AllPairs::new(params.near_field.precision));
        Self {
            law,
            drag: Drag::new(params),
            field: params.field(),
            electric_field: params.electric_field(),
            contacts: NeighborList::new(CONTACT_SKIN * params.radius),
            near,
            tree: (near_field && theta > 0.0).then(|| (Octree::default(), theta)),
            all_pairs,
            near_forces: vec![Vector3::zeros(); n],
            fresh: vec![Vec::new(); n],
            unbonded: vec![Vec::new(); n],
            bond_index: BondIndex::new(n),
            radii: vec![params.radius; n],
            near_radii: vec![0.5 * cutoff; n],
            times: StageTimes::default(),
        }
    }

    /// The pair law in use.
    pub fn law(&self) -> &PairLaw {
        &self.law
    }

    /// All-pairs near-field evaluations so far: (all, in single precision); (0, 0) where the
    /// near field is off or summed by a cut-off list or a tree.
    pub fn all_pairs_evaluations(&self) -> (usize, usize) {
        self.all_pairs
            .as_ref()
            .map_or((0, 0), AllPairs::evaluations)
    }

    /// Wall-clock time each stage has taken so far.
    pub fn stage_times(&self) -> StageTimes {
        self.times
    }

    /// Number of bonded pairs.
    pub fn bond_count(&self) -> usize {
        self.bond_index.count()
    }

    /// Bonded pairs (i < j).
    pub fn bonded_pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.bond_index.bonded_pairs()
    }

    /// Forces (N) and moments (N·m) on every particle at the state (positions, velocities,
    /// spins) with regularization step `dt`; written into `forces` and `moments`.
    pub fn evaluate(
        &mut self,
        cloud: &Cloud,
        dt: f64,
        forces: &mut [Vector3<f64>],
        moments: &mut [Vector3<f64>],
    ) {
        let mut mark = Instant::now();
        let flags = self.law.flags;
        if flags.contact || flags.damping || flags.friction || flags.bonding {
            self.update_contacts(cloud);
        }
        lap(&mut self.times.contacts, &mut mark);
        self.prepare_near_field(cloud);
        lap(&mut self.times.near_field, &mut mark);
        self.bond_index.evaluate(&self.law, cloud, dt);
        lap(&mut self.times.bonds, &mut mark);
        let this = &*self;
        forces
            .par_iter_mut()
            .zip(moments.par_iter_mut())
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(i, (f, m))| (*f, *m) = this.on_particle(cloud, i, dt));
        lap(&mut self.times.gather, &mut mark);
    }

    /// Rebuilds the contact list if a particle has moved far enough, and then each
    /// particle's unbonded contacts (a merged walk: both lists ascend).
    fn update_contacts(&mut self, cloud: &Cloud) {
        if !self.contacts.update(&cloud.positions, &self.radii) {
            return;
        }
        let (contacts, bonds) = (&self.contacts, &self.bond_index);
        self.unbonded
            .par_iter_mut()
            .enumerate()
            .with_min_len(CHUNK)
            .for_each(|(i, row)| {
                row.clear();
                let mut bonded = bonds.partners(i).peekable();
                for &j in contacts.of(i) {
                    while bonded.next_if(|&b| b < j).is_some() {}
                    if bonded.peek() != Some(&j) {
                        row.push(j);
                    }
                }
            });
    }

    /// Updates the near field's cut-off list, or sums it by the tree or the all-pairs kernel.
    fn prepare_near_field(&mut self, cloud: &Cloud) {
        if let Some((list, _)) = &mut self.near {
            list.update(&cloud.positions, &self.near_radii);
        }
        if let Some((tree, theta)) = &mut self.tree {
            tree.build(&cloud.positions);
            let law = &self.law;
            tree.sum_all(*theta, |a, b| law.near_field(a, b), &mut self.near_forces);
        }
        if let Some(kernel) = &mut self.all_pairs {
            let (x, q) = (&cloud.positions, &cloud.charge_per_mass);
            kernel.sum(&self.law, x, q, &mut self.near_forces);
        }
    }

    /// The near-field force on every particle of `cloud` by the method in use (C8), N.
    pub fn near_field(&mut self, cloud: &Cloud) -> Vec<Vector3<f64>> {
        self.prepare_near_field(cloud);
        (0..cloud.len())
            .map(|i| self.near_field_on(cloud, i))
            .collect()
    }

    /// Force and moment on particle i.
    fn on_particle(&self, cloud: &Cloud, i: usize, dt: f64) -> (Vector3<f64>, Vector3<f64>) {
        let v = cloud.velocities[i];
        let accel = lorentz_acceleration(
            cloud.charge_per_mass[i],
            &self.electric_field,
            &self.field,
            &v,
        ) + self.drag.acceleration(&v);
        let mut force = cloud.mass * accel;
        let mut moment = Vector3::zeros();
        let body = |k: usize| Body {
            position: cloud.positions[k],
            velocity: cloud.velocities[k],
            spin: cloud.spins[k],
        };
        let me = body(i);
        let flags = self.law.flags;
        if flags.contact || flags.damping || flags.friction {
            // bonded pairs are handled below, touching or not
            for &j in &self.unbonded[i] {
                let (f, m) = self.law.contact(&me, &body(j as usize), None, dt);
                force += f;
                moment += m;
            }
        }
        for (f, m) in self.bond_index.wrenches_on(i) {
            force += f;
            moment += m;
        }
        if flags.near_field {
            force += self.near_field_on(cloud, i);
        }
        (force, moment)
    }

    /// Near-field force on i: exact over all j, over the cut-off list, or from the tree
    /// (the tree and the all-pairs kernel have summed it already).
    fn near_field_on(&self, cloud: &Cloud, i: usize) -> Vector3<f64> {
        let ri = &cloud.positions[i];
        if self.tree.is_some() || self.all_pairs.is_some() {
            return self.near_forces[i];
        }
        let q = &cloud.charge_per_mass;
        let pair = |j: usize| {
            self.law.sign_factor(q[i], q[j]) * self.law.near_field(ri, &cloud.positions[j])
        };
        let mut sum = Vector3::zeros();
        match &self.near {
            None => {
                for j in (0..cloud.len()).filter(|&j| j != i) {
                    sum += pair(j);
                }
            }
            Some((list, cutoff)) => {
                for j in list.of(i).iter().map(|&j| j as usize) {
                    if (cloud.positions[j] - ri).norm_squared() < cutoff * cutoff {
                        sum += pair(j);
                    }
                }
            }
        }
        sum
    }

    /// Bonds every touching pair whose overlap strain has reached ε* (C7); bonds are
    /// permanent. Returns the number of new bonds. Each particle finds its new partners in
    /// parallel (each pair from both sides: the strain is symmetric); the pairs are then
    /// added from their lower particle's side, in ascending order of both, so the bonds'
    /// order does not depend on the thread count.
    pub fn form_bonds(&mut self, cloud: &Cloud) -> usize {
        let mut mark = Instant::now();
        let added = self.add_new_bonds(cloud);
        lap(&mut self.times.bond_formation, &mut mark);
        added
    }

    /// [`Interactor::form_bonds`], untimed.
    fn add_new_bonds(&mut self, cloud: &Cloud) -> usize {
        if !self.law.flags.bonding {
            return 0;
        }
        self.update_contacts(cloud);
        let radius = self.law.radius;
        let threshold = self.law.contact.bond_strain;
        // strain ≥ ε* needs dist ≤ 2R(1 − ε*): pairs clearly farther skip the square root
        let reach = (2.0 * radius * (1.0 - threshold)).max(0.0);
        let positions = &cloud.positions;
        let found = self
            .fresh
            .par_iter_mut()
            .zip(&mut self.unbonded)
            .enumerate()
            .with_min_len(CHUNK)
            .map(|(i, (fresh, unbonded))| {
                fresh.clear();
                for &j in unbonded.iter() {
                    let d = positions[j as usize] - positions[i];
                    if clearly_beyond(&d, reach) {
                        continue;
                    }
                    let dist = d.norm();
                    let strain = (2.0 * radius - dist) / (2.0 * radius);
                    if strain >= threshold {
                        fresh.push((j, contact_area(radius, dist)));
                    }
                }
                if !fresh.is_empty() {
                    // the new partners ascend, as the unbonded contacts they came from
                    let mut new = fresh.iter().map(|&(j, _)| j).peekable();
                    unbonded.retain(|&j| new.next_if_eq(&j).is_none());
                }
                fresh.len()
            })
            .sum::<usize>();
        if found == 0 {
            return 0;
        }
        let before = self.bond_index.count();
        for (i, fresh) in self.fresh.iter().enumerate() {
            for &(j, area) in fresh.iter().filter(|&&(j, _)| j as usize > i) {
                self.bond_index.add(i, j as usize, area);
            }
        }
        let added = self.bond_index.count() - before;
        self.bond_index.tidy();
        debug_assert_eq!(found, 2 * added, "each new bond is found from both sides");
        added
    }
}

/// The error of `params`' near-field method on `cloud` against the exact double-precision
/// sum over all pairs: (largest error / largest exact force, rms error / rms exact force).
/// Zero for the exact method itself.
pub fn near_field_error(params: &BlastParams, cloud: &Cloud) -> (f64, f64) {
    let mut exact_params = params.clone();
    exact_params.interactions.near_field = true;
    let n = &mut exact_params.near_field;
    (n.cutoff, n.theta, n.precision) = (0.0, 0.0, NearFieldPrecision::Double);
    let exact = Interactor::new(&exact_params, cloud.len()).near_field(cloud);
    let mut method_params = params.clone();
    method_params.interactions.near_field = true;
    let method = Interactor::new(&method_params, cloud.len()).near_field(cloud);
    let errors: Vec<f64> = exact
        .iter()
        .zip(&method)
        .map(|(e, m)| (e - m).norm())
        .collect();
    let sizes: Vec<f64> = exact.iter().map(|e| e.norm()).collect();
    let largest = |v: &[f64]| v.iter().fold(0.0, |a: f64, &b| a.max(b));
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    (
        largest(&errors) / largest(&sizes),
        rms(&errors) / rms(&sizes),
    )
}
