//! A particle's Hertz contact sums over its listed neighbours, four entries at a time (issue
//! 18, item 4: the packing's force evaluations are 94 % of an align run at N = 10⁵, and this
//! gather was 71 % of their samples).
//!
//! The portable form ([`ContactLaw::particle_contacts_of`] and [`super::gather`]) takes each
//! entry on its own: a branch on the squared distance (at N = 10⁵ two thirds of the entries
//! pass it), then, for a contact, three roots and four divisions in one dependent chain. The
//! AVX form tests four entries at a time for reach, keeps those within it in list order, and
//! computes the terms of four kept entries side by side; it then subtracts each entry's
//! (f n, −k) from the running sums one entry at a time, in list order, with the portable
//! form's operations (none fused): the same bits. An entry within reach that is no contact
//! (the exact tests after the root) has the row +0, and x − (+0) = x for every x, −0
//! included, so dropping it is the portable form's skipping. The largest overlap is
//! order-free.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use nalgebra::Vector3;

use super::Load;
use crate::models::align::dem::contacts::ContactLaw;
use crate::neighbor::NeighborList;
#[cfg(target_arch = "x86_64")]
use crate::numerics::lanes::transpose4;

/// Adds particle i's Hertz contacts with its listed neighbours to `load` (net force,
/// summed stiffness, largest overlap, particle contacts), as [`super::gather`] adds those that
/// [`ContactLaw::particle_contacts_of`] emits: with AVX where the processor has it.
pub(super) fn add_particle_contacts(
    law: &ContactLaw,
    i: usize,
    position: &[Vector3<f64>],
    radius: &[f64],
    neighbors: &NeighborList,
    load: &mut Load,
) {
    #[cfg(target_arch = "x86_64")]
    if crate::numerics::has_avx() {
        let listed = neighbors.of(i);
        // SAFETY: the processor has AVX.
        return unsafe { add_particle_contacts_avx(law, i, position, radius, listed, load) };
    }
    law.particle_contacts_of(i, position, radius, neighbors, |_, c| {
        super::gather(super::Repulsion::Hertz, load, &c)
    });
}

/// The AVX form: the entries tested for reach four at a time; those within reach summed in
/// list order, four at a time (the last group padded with i itself: distance 0, never a
/// contact).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn add_particle_contacts_avx(
    law: &ContactLaw,
    i: usize,
    position: &[Vector3<f64>],
    radius: &[f64],
    listed: &[u32],
    load: &mut Load,
) {
    let own = own(law, i, position, radius);
    let mut acc = Sums {
        rows: _mm256_set_pd(load.1, load.0.z, load.0.y, load.0.x),
        deepest: _mm256_setzero_pd(),
        count: 0,
    };
    // In blocks of listed entries: first the entries within reach, in list order, without a
    // branch; then their sums four at a time, in a loop whose branch the processor predicts
    // (a branch on each four's count between the two stalled the kernel on mispredictions).
    let mut within_reach_of = [i; BLOCK];
    for block in listed.chunks(BLOCK) {
        let mut kept = 0;
        for four in block.chunks(4) {
            let j = [0, 1, 2, 3].map(|k| four.get(k).map_or(i, |&j| j as usize));
            // SAFETY (this and the call below): the processor has AVX.
            let within = unsafe { within_reach(&own, load_four(position, radius, j)) };
            for (k, &j) in j.iter().enumerate() {
                within_reach_of[kept] = j;
                kept += (within >> k) & 1;
            }
        }
        for four in within_reach_of[..kept].chunks(4) {
            unsafe { add_four(&mut acc, &own, position, radius, four) };
        }
    }
    let (mut s, mut d) = ([0.0; 4], [0.0; 4]);
    // SAFETY: each array holds 4 f64.
    unsafe {
        _mm256_storeu_pd(s.as_mut_ptr(), acc.rows);
        _mm256_storeu_pd(d.as_mut_ptr(), acc.deepest);
    }
    load.0 = Vector3::new(s[0], s[1], s[2]);
    load.1 = s[3];
    load.2 = d.into_iter().fold(load.2, f64::max);
    load.3 += acc.count;
}

/// Calls `emit(j, n, k)` for each of particle i's listed neighbours j that touches it with
/// stiffness k > 0 (n: the unit normal towards j), in list order: the contacts that
/// [`ContactLaw::particle_contacts_of`] emits and whose Hertz stiffness is positive, with the
/// same bits; with AVX where the processor has it (the release's linearization, which took
/// about as long as a force evaluation with the portable form).
pub(super) fn touching_contacts(
    law: &ContactLaw,
    i: usize,
    position: &[Vector3<f64>],
    radius: &[f64],
    neighbors: &NeighborList,
    mut emit: impl FnMut(u32, Vector3<f64>, f64),
) {
    #[cfg(target_arch = "x86_64")]
    if crate::numerics::has_avx() {
        let listed = neighbors.of(i);
        // SAFETY: the processor has AVX.
        return unsafe { touching_contacts_avx(law, i, position, radius, listed, &mut emit) };
    }
    law.particle_contacts_of(i, position, radius, neighbors, |j, c| {
        let k = c.stiffness_at(c.overlap);
        if k > 0.0 {
            emit(j, c.normal, k);
        }
    });
}

/// The AVX form of [`touching_contacts`], four entries at a time.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn touching_contacts_avx(
    law: &ContactLaw,
    i: usize,
    position: &[Vector3<f64>],
    radius: &[f64],
    listed: &[u32],
    emit: &mut impl FnMut(u32, Vector3<f64>, f64),
) {
    let own = own(law, i, position, radius);
    for four in listed.chunks(4) {
        let j = [0, 1, 2, 3].map(|k| four.get(k).map_or(i, |&j| j as usize));
        // SAFETY (these calls): the processor has AVX; each array holds 4 f64.
        let t = unsafe { four_terms(&own, load_four(position, radius, j)) };
        let touching = _mm256_cmp_pd::<_CMP_GT_OQ>(t.stiffness, _mm256_setzero_pd());
        let mut hits = _mm256_movemask_pd(touching);
        if hits == 0 {
            continue;
        }
        let lanes = |v| {
            let mut out = [0.0; 4];
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), v) };
            out
        };
        let ([nx, ny, nz], k) = (t.normal.map(lanes), lanes(t.stiffness));
        while hits != 0 {
            let lane = hits.trailing_zeros() as usize;
            emit(
                j[lane] as u32,
                Vector3::new(nx[lane], ny[lane], nz[lane]),
                k[lane],
            );
            hits &= hits - 1;
        }
    }
}

/// Listed entries tested for reach before their sums are taken (a multiple of 4; rows longer
/// than this are taken block by block, the same bits: a group's padding adds +0 rows).
#[cfg(target_arch = "x86_64")]
const BLOCK: usize = 32;

/// The running sums of the AVX form: the load's (F_x, F_y, F_z, Σ k), from which each
/// entry's row (f n_x, f n_y, f n_z, −k) is subtracted; the largest overlap per lane; the
/// contacts.
#[cfg(target_arch = "x86_64")]
struct Sums {
    rows: __m256d,
    deepest: __m256d,
    count: u32,
}

/// Subtracts the rows of up to four entries (partners `entries`) from the sums in entry
/// order, and adds their overlaps and contacts (fewer than four: padded with the particle
/// itself, at distance 0, never a contact).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn add_four(
    acc: &mut Sums,
    own: &Own,
    position: &[Vector3<f64>],
    radius: &[f64],
    entries: &[usize],
) {
    let j = [0, 1, 2, 3].map(|k| entries.get(k).copied().unwrap_or(own.index));
    // SAFETY: the processor has AVX.
    let (rows, overlap, kept) = unsafe { four_entries(own, load_four(position, radius, j)) };
    for row in rows {
        acc.rows = _mm256_sub_pd(acc.rows, row);
    }
    acc.deepest = _mm256_max_pd(overlap, acc.deepest);
    acc.count += (_mm256_movemask_pd(kept) as u32).count_ones();
}

/// Particle i's centre, radius and the law's constants, in every lane.
#[cfg(target_arch = "x86_64")]
struct Own {
    index: usize,
    x: __m256d,
    y: __m256d,
    z: __m256d,
    r: __m256d,
    skin: __m256d,
    /// (4/3) E*/E.
    modulus: __m256d,
}

/// Particle i's [`Own`].
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn own(law: &ContactLaw, i: usize, position: &[Vector3<f64>], radius: &[f64]) -> Own {
    Own {
        index: i,
        x: _mm256_set1_pd(position[i].x),
        y: _mm256_set1_pd(position[i].y),
        z: _mm256_set1_pd(position[i].z),
        r: _mm256_set1_pd(radius[i]),
        skin: _mm256_set1_pd(law.skin),
        modulus: _mm256_set1_pd(4.0 / 3.0 * law.effective_modulus),
    }
}

/// Four entries' centres and radii, one coordinate per register.
#[cfg(target_arch = "x86_64")]
struct Four {
    x: __m256d,
    y: __m256d,
    z: __m256d,
    r: __m256d,
}

/// The centres and radii of particles `j`.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn load_four(position: &[Vector3<f64>], radius: &[f64], j: [usize; 4]) -> Four {
    let p = j.map(|j| &position[j]);
    Four {
        x: _mm256_set_pd(p[3].x, p[2].x, p[1].x, p[0].x),
        y: _mm256_set_pd(p[3].y, p[2].y, p[1].y, p[0].y),
        z: _mm256_set_pd(p[3].z, p[2].z, p[1].z, p[0].z),
        r: _mm256_set_pd(radius[j[3]], radius[j[2]], radius[j[1]], radius[j[0]]),
    }
}

/// The portable form's first test of four entries: bit k set where entry k is not beyond
/// reach (its squared distance not above (R_i + R_j + skin)² (1 + 10⁻⁹)).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn within_reach(own: &Own, q: Four) -> usize {
    let (_, d2, limit) = reach_test(own, &q);
    _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_NGT_UQ>(d2, limit)) as usize
}

/// The separations of four entries (q − p), their squares and the squares they are tested
/// against, with the portable form's operations in its order (nalgebra's norm_squared:
/// (x² + y²) + z²).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn reach_test(own: &Own, q: &Four) -> ([__m256d; 3], __m256d, __m256d) {
    let (dx, dy, dz) = (
        _mm256_sub_pd(q.x, own.x),
        _mm256_sub_pd(q.y, own.y),
        _mm256_sub_pd(q.z, own.z),
    );
    let mul = |a, b| _mm256_mul_pd(a, b);
    let d2 = _mm256_add_pd(_mm256_add_pd(mul(dx, dx), mul(dy, dy)), mul(dz, dz));
    let reach = _mm256_add_pd(_mm256_add_pd(own.r, q.r), own.skin);
    let limit = mul(mul(reach, reach), _mm256_set1_pd(1.0 + 1e-9));
    ([dx, dy, dz], d2, limit)
}

/// Four entries' contact terms side by side, with the portable form's operations in its
/// order: the unit normals, the force and stiffness (+0 where not touching), the overlap, and
/// the mask of the contacts.
#[cfg(target_arch = "x86_64")]
struct Terms {
    normal: [__m256d; 3],
    force: __m256d,
    stiffness: __m256d,
    overlap: __m256d,
    kept: __m256d,
}

/// The terms of four entries.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn four_terms(own: &Own, q: Four) -> Terms {
    let ([dx, dy, dz], d2, limit) = reach_test(own, &q);
    let r_j = q.r;
    let mul = |a, b| _mm256_mul_pd(a, b);
    let sum_r = _mm256_add_pd(own.r, r_j);
    let dist = _mm256_sqrt_pd(d2);
    let overlap = _mm256_sub_pd(sum_r, dist);
    let zero = _mm256_setzero_pd();
    let minus = _mm256_set1_pd(-0.0);
    let kept = _mm256_and_pd(
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_NGT_UQ>(d2, limit),
            _mm256_cmp_pd::<_CMP_GT_OQ>(overlap, _mm256_xor_pd(own.skin, minus)),
        ),
        _mm256_cmp_pd::<_CMP_GT_OQ>(dist, zero),
    );
    let r_star = _mm256_div_pd(mul(own.r, r_j), sum_r);
    let hertz = mul(own.modulus, _mm256_sqrt_pd(r_star));
    let root = _mm256_sqrt_pd(overlap);
    let touching = _mm256_and_pd(kept, _mm256_cmp_pd::<_CMP_GT_OQ>(overlap, zero));
    Terms {
        normal: [dx, dy, dz].map(|d| _mm256_div_pd(d, dist)),
        force: _mm256_and_pd(touching, mul(mul(hertz, overlap), root)),
        stiffness: _mm256_and_pd(touching, mul(mul(_mm256_set1_pd(1.5), hertz), root)),
        overlap,
        kept,
    }
}

/// Four entries side by side: each entry's row (f n_x, f n_y, f n_z, −k), +0 where it is no
/// contact; the overlaps of the contacts (+0 elsewhere); the mask of the contacts.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn four_entries(own: &Own, q: Four) -> ([__m256d; 4], __m256d, __m256d) {
    let t = unsafe { four_terms(own, q) };
    let kept = t.kept;
    let along = |n| _mm256_and_pd(kept, _mm256_mul_pd(t.force, n));
    let [fx, fy, fz] = t.normal.map(along);
    let minus_k = _mm256_and_pd(kept, _mm256_xor_pd(t.stiffness, _mm256_set1_pd(-0.0)));
    // rows (f n_x, f n_y, f n_z, −k) of entries 0–3
    let rows = unsafe { transpose4([fx, fy, fz, minus_k]) };
    (rows, _mm256_and_pd(kept, t.overlap), kept)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::align::dem::packing::{gather, Repulsion};

    /// Where the processor has AVX, the AVX sums are the portable form's bit for bit: for a
    /// dense jumble of three sizes of spheres (rows of every length, and so remainders of 0–3
    /// entries, some rows spanning several blocks), with and without a contact skin (contacts
    /// emitted at a gap), starting from loads that are not zero (the settling force, a −0
    /// among them).
    #[test]
    fn avx_and_portable_sums_are_identical() {
        #[cfg(target_arch = "x86_64")]
        if !crate::numerics::has_avx() {
            return;
        }
        let (radius, position, list) = jumble();
        let n = radius.len();
        let (mut lengths, mut contacts) = (std::collections::BTreeSet::new(), 0);
        let longest = (0..n).map(|i| list.of(i).len()).max().unwrap();
        #[cfg(target_arch = "x86_64")]
        assert!(longest > 2 * BLOCK, "rows across blocks: {longest}");
        for skin in [0.0, 0.2] {
            let law = law(skin);
            for i in 0..n {
                lengths.insert(list.of(i).len() % 4);
                let start: Load = (Vector3::new(0.0, -0.0, -0.25 * i as f64), 0.0, 0.0, 0);
                let mut portable = start;
                law.particle_contacts_of(i, &position, &radius, &list, |_, c| {
                    gather(Repulsion::Hertz, &mut portable, &c)
                });
                let mut lanes = start;
                add_particle_contacts(&law, i, &position, &radius, &list, &mut lanes);
                let bits = |l: Load| {
                    let v = [l.0.x, l.0.y, l.0.z, l.1, l.2].map(f64::to_bits);
                    (v, l.3)
                };
                assert_eq!(bits(portable), bits(lanes), "particle {i}, skin {skin}");
                contacts += lanes.3;
            }
        }
        assert!(contacts > 2 * n as u32, "{contacts}");
        assert_eq!(lengths.len(), 4, "every remainder: {lengths:?}");
    }

    /// A dense jumble of 400 spheres of three sizes and its list (skin 0.3): rows of every
    /// length, some spanning several blocks.
    fn jumble() -> (Vec<f64>, Vec<Vector3<f64>>, NeighborList) {
        let n = 400;
        let radius: Vec<f64> = (0..n).map(|k| [1.0, 0.7, 1.3][k % 3]).collect();
        let position: Vec<_> = (0..n)
            .map(|k| {
                let t = k as f64;
                Vector3::new(
                    6.0 * (1.3 * t).sin().abs(),
                    6.0 * (0.7 * t).cos().abs(),
                    6.0 * (0.37 * t).sin().abs(),
                )
            })
            .collect();
        let mut list = NeighborList::new(0.3);
        list.build(&position, &radius);
        (radius, position, list)
    }

    fn law(skin: f64) -> ContactLaw {
        ContactLaw {
            effective_modulus: 0.55,
            friction: 0.0,
            wall_friction: 0.0,
            skin,
        }
    }

    /// The touching contacts the release's linearization stores: the AVX form emits the
    /// portable form's partners, normals and stiffnesses bit for bit, in list order (with and
    /// without a contact skin, which emits contacts at a gap that touch nothing).
    #[test]
    fn avx_and_portable_touching_contacts_are_identical() {
        // without AVX both sides are the portable form: nothing to compare
        #[cfg(target_arch = "x86_64")]
        if !crate::numerics::has_avx() {
            return;
        }
        let (radius, position, list) = jumble();
        let mut touching = 0;
        for skin in [0.0, 0.2] {
            let law = law(skin);
            for i in 0..radius.len() {
                let bits = |j: u32, n: Vector3<f64>, k: f64| (j, n.map(f64::to_bits), k.to_bits());
                let mut portable = Vec::new();
                law.particle_contacts_of(i, &position, &radius, &list, |j, c| {
                    let k = c.stiffness_at(c.overlap);
                    if k > 0.0 {
                        portable.push(bits(j, c.normal, k));
                    }
                });
                let mut lanes = Vec::new();
                touching_contacts(&law, i, &position, &radius, &list, |j, n, k| {
                    lanes.push(bits(j, n, k))
                });
                assert_eq!(portable, lanes, "particle {i}, skin {skin}");
                touching += lanes.len();
            }
        }
        assert!(touching > 2 * radius.len(), "{touching}");
    }
}
