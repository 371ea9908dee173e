//! Each disk's pair sums over its list partners (B1 force, B4 normal force, the stiffest pair
//! and the closest approach), from the pair geometry of [`super::list_pairs::HalfList`].
//!
//! The sums add the partners' terms one by one in list order, so they do not depend on the
//! thread count. The AVX form computes the terms of four entries per instruction and then adds
//! them to the running sums one entry at a time, in the same order and with the same
//! operations (none fused) as the portable form: the same bits. The maxima are order-free
//! (every term ≥ 0; a NaN term leaves them as [`larger`] does) and are kept per lane.

#[cfg(target_arch = "x86_64")]
use crate::numerics::lanes::transpose4;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use super::forces::{larger, PairSums};
use super::list_pairs::{Row, Separation};

/// What a particle contributes to its partners' pair sums, stored together so the pair loop
/// reads one record per partner.
#[derive(Debug, Clone, Copy)]
pub(super) struct Partner {
    /// μ_j, A·m².
    pub(super) moment: f64,
    /// μ_j sin θ_j, A·m² (B4).
    pub(super) moment_sin: f64,
    /// D_j, m.
    pub(super) diameter: f64,
}

/// Every particle's [`Partner`] record, and whether they are all the same (a mono-disperse
/// bed): then the AVX form takes the first record for every entry instead of loading each
/// entry's (the same values, so the same bits).
#[derive(Debug, Clone, Copy)]
pub(super) struct Partners<'a> {
    pub(super) each: &'a [Partner],
    /// Read by the AVX form only.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) uniform: bool,
}

impl<'a> Partners<'a> {
    /// The records, `uniform` when every one has the bits of the first.
    pub(super) fn new(each: &'a [Partner]) -> Self {
        let bits = |p: &Partner| [p.moment, p.moment_sin, p.diameter].map(f64::to_bits);
        let uniform = each.iter().all(|p| bits(p) == bits(&each[0]));
        Self { each, uniform }
    }
}

/// Disk i's pair sums over the entries of its list row (`own_diameter` = D_i), with AVX where
/// the processor has it.
pub(super) fn pair_sums(row: &Row, partner: Partners, own_diameter: f64) -> PairSums {
    #[cfg(target_arch = "x86_64")]
    if crate::numerics::has_avx() {
        // SAFETY: the processor has AVX.
        return unsafe { pair_sums_avx(row, partner, own_diameter) };
    }
    pair_sums_portable(row, partner.each, own_diameter)
}

/// The portable form: the entries one by one.
fn pair_sums_portable(row: &Row, partner: &[Partner], own_diameter: f64) -> PairSums {
    row.entries().fold(PairSums::default(), |mut acc, (j, s)| {
        let partner = &partner[j];
        let mu_r5 = partner.moment * s.inv_r3 * s.inv_r2;
        acc.force += s.d * mu_r5;
        acc.normal += partner.moment_sin * s.inv_r3;
        let mean_d = 0.5 * (own_diameter + partner.diameter);
        acc.stiffest = larger(acc.stiffest, mu_r5);
        acc.closeness = larger(acc.closeness, mean_d * mean_d * s.inv_r2);
        acc
    })
}

/// Running sums of the AVX form: (Σ f_x, Σ f_y, Σ normal, 0) in one register, the maxima per
/// lane.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Lanes {
    sums: __m256d,
    stiffest: __m256d,
    closeness: __m256d,
}

/// The AVX form: the entries below the disk, then those above it, each in fours with the
/// remainder one by one.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn pair_sums_avx(row: &Row, partners: Partners, own_diameter: f64) -> PairSums {
    let mut acc = Lanes {
        sums: _mm256_setzero_pd(),
        stiffest: _mm256_setzero_pd(),
        closeness: _mm256_setzero_pd(),
    };
    let own = _mm256_set1_pd(own_diameter);
    let partner = partners.each;
    let same = (partners.uniform && !partner.is_empty()).then(|| {
        let p = &partner[0];
        PartnerLanes {
            moment: _mm256_set1_pd(p.moment),
            moment_sin: _mm256_set1_pd(p.moment_sin),
            diameter: _mm256_set1_pd(p.diameter),
        }
    });
    // SAFETY: the processor has AVX.
    let lanes = |js: &[u32]| same.unwrap_or_else(|| unsafe { gather_partners(js, partner) });
    let split = row.below.len() - row.below.len() % 4;
    for (js, slots) in row.below[..split]
        .chunks_exact(4)
        .zip(row.slots[..split].chunks_exact(4))
    {
        let t = [0, 1, 2, 3].map(|k| &row.terms[slots[k] as usize]);
        // SAFETY: the processor has AVX.
        unsafe { add_four(&mut acc, t, lanes(js), own, true) };
    }
    for (&j, &s) in row.below[split..].iter().zip(&row.slots[split..]) {
        // SAFETY: as above.
        unsafe {
            add_one(
                &mut acc,
                &row.terms[s as usize],
                j,
                partner,
                own_diameter,
                true,
            )
        };
    }
    let split = row.above.len() - row.above.len() % 4;
    for (js, t) in row.above[..split]
        .chunks_exact(4)
        .zip(row.above_terms[..split].chunks_exact(4))
    {
        let t = [&t[0], &t[1], &t[2], &t[3]];
        // SAFETY: as above.
        unsafe { add_four(&mut acc, t, lanes(js), own, false) };
    }
    for (&j, t) in row.above[split..].iter().zip(&row.above_terms[split..]) {
        // SAFETY: as above.
        unsafe { add_one(&mut acc, t, j, partner, own_diameter, false) };
    }
    let mut v = [[0.0; 4]; 3];
    for (v, lanes) in v.iter_mut().zip([acc.sums, acc.stiffest, acc.closeness]) {
        // SAFETY: each array holds 4 f64.
        unsafe { _mm256_storeu_pd(v.as_mut_ptr(), lanes) };
    }
    let most = |v: [f64; 4]| v.into_iter().fold(0.0, larger);
    PairSums {
        force: [v[0][0], v[0][1]].into(),
        normal: v[0][2],
        stiffest: most(v[1]),
        closeness: most(v[2]),
    }
}

/// The [`Partner`] records of four entries, one field per register.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct PartnerLanes {
    moment: __m256d,
    moment_sin: __m256d,
    diameter: __m256d,
}

/// The records of partners `js[0..4]`.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn gather_partners(js: &[u32], partner: &[Partner]) -> PartnerLanes {
    let p = [0, 1, 2, 3].map(|k| &partner[js[k] as usize]);
    let field = |f: fn(&Partner) -> f64| _mm256_set_pd(f(p[3]), f(p[2]), f(p[1]), f(p[0]));
    PartnerLanes {
        moment: field(|p| p.moment),
        moment_sin: field(|p| p.moment_sin),
        diameter: field(|p| p.diameter),
    }
}

/// Adds four entries: their terms side by side, then each entry's (f_x, f_y, normal) to the
/// sums in entry order. `below`: the separations are seen from the other disk (negated).
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn add_four(
    acc: &mut Lanes,
    t: [&Separation; 4],
    p: PartnerLanes,
    own: __m256d,
    below: bool,
) {
    // SAFETY: a Separation is four f64 (dx, dy, 1/r², 1/r³; repr(C)).
    let load = |t: &Separation| unsafe { _mm256_loadu_pd((t as *const Separation).cast()) };
    // SAFETY: the processor has AVX.
    let [mut dx, mut dy, inv_r2, inv_r3] = unsafe { transpose4(t.map(load)) };
    if below {
        let sign = _mm256_set1_pd(-0.0);
        (dx, dy) = (_mm256_xor_pd(dx, sign), _mm256_xor_pd(dy, sign));
    }
    let PartnerLanes {
        moment,
        moment_sin,
        diameter,
    } = p;
    let mu_r5 = _mm256_mul_pd(_mm256_mul_pd(moment, inv_r3), inv_r2);
    let (fx, fy) = (_mm256_mul_pd(dx, mu_r5), _mm256_mul_pd(dy, mu_r5));
    let normal = _mm256_mul_pd(moment_sin, inv_r3);
    let mean_d = _mm256_mul_pd(_mm256_set1_pd(0.5), _mm256_add_pd(own, diameter));
    let closeness = _mm256_mul_pd(_mm256_mul_pd(mean_d, mean_d), inv_r2);
    // max(new, old) keeps the old value against a NaN term, as `larger` does
    acc.stiffest = _mm256_max_pd(mu_r5, acc.stiffest);
    acc.closeness = _mm256_max_pd(closeness, acc.closeness);
    // rows (f_x, f_y, normal, 0) of entries 0–3
    // SAFETY: the processor has AVX.
    for row in unsafe { transpose4([fx, fy, normal, _mm256_setzero_pd()]) } {
        acc.sums = _mm256_add_pd(acc.sums, row);
    }
}

/// Adds one entry, with the portable form's operations.
///
/// # Safety
/// Only where the processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn add_one(
    acc: &mut Lanes,
    t: &Separation,
    j: u32,
    partner: &[Partner],
    own_diameter: f64,
    below: bool,
) {
    let p = &partner[j as usize];
    let d = if below { -t.d } else { t.d };
    let mu_r5 = p.moment * t.inv_r3 * t.inv_r2;
    let f = d * mu_r5;
    let mean_d = 0.5 * (own_diameter + p.diameter);
    let closeness = mean_d * mean_d * t.inv_r2;
    acc.sums = _mm256_add_pd(
        acc.sums,
        _mm256_set_pd(0.0, p.moment_sin * t.inv_r3, f.y, f.x),
    );
    acc.stiffest = _mm256_max_pd(_mm256_set1_pd(mu_r5), acc.stiffest);
    acc.closeness = _mm256_max_pd(_mm256_set1_pd(closeness), acc.closeness);
}

#[cfg(test)]
mod tests {
    use super::super::list_pairs::HalfList;
    use super::*;
    use crate::neighbor::NeighborList;
    use nalgebra::Vector2;

    /// Where the processor has AVX, the AVX sums are the portable sums bit for bit, for rows
    /// of every length (remainders below and above the disk), disks of three sizes, moments
    /// and tilts, and pairs inside and outside the range; and for disks all alike, whose
    /// records the AVX form takes from the first.
    #[test]
    fn avx_and_portable_sums_are_identical() {
        #[cfg(target_arch = "x86_64")]
        if !std::arch::is_x86_feature_detected!("avx") {
            return;
        }
        let n = 170;
        let position: Vec<_> = (0..n)
            .map(|k| {
                let t = k as f64;
                Vector2::new((1.3 * t).sin() * t.sqrt(), (0.7 * t).cos() * 5.0)
            })
            .collect();
        let mixed: Vec<_> = (0..n)
            .map(|k| Partner {
                moment: [1.0, 0.3, 2.7][k % 3],
                moment_sin: [0.1, 0.0, 0.4][k % 3],
                diameter: [1.0, 0.5, 1.3][k % 3],
            })
            .collect();
        let same = vec![mixed[2]; n];
        let mut list = NeighborList::<2>::new(0.5);
        list.build(&position, &vec![1.0; n]);
        let mut half = HalfList::default();
        half.evaluate(&list, &position, (0.09, 2.25));
        let bits = |s: PairSums| {
            [s.force.x, s.force.y, s.normal, s.stiffest, s.closeness].map(f64::to_bits)
        };
        let (mut lengths, mut pushed) = (std::collections::BTreeSet::new(), 0);
        for partner in [&mixed, &same] {
            let partners = Partners::new(partner);
            assert_eq!(partners.uniform, std::ptr::eq(partner, &same));
            for i in 0..n {
                let row = half.row(&list, i);
                lengths.insert((row.below.len() % 4, row.above.len() % 4));
                let own = partner[i].diameter;
                let portable = pair_sums_portable(&row, partner, own);
                // SAFETY: the processor has AVX (checked above).
                #[cfg(target_arch = "x86_64")]
                let avx = unsafe { pair_sums_avx(&row, partners, own) };
                #[cfg(target_arch = "x86_64")]
                assert_eq!(bits(avx), bits(portable), "disk {i}");
                pushed += usize::from(portable.force.norm() > 0.0);
            }
        }
        assert!(lengths.len() >= 12, "remainders met: {lengths:?}");
        assert!(pushed > n, "{pushed} disks with pairs in range");
    }
}
