//! Settled packings kept on disk between processes (`magopt align --packing-cache DIR`): a
//! study reuses one packing per (packing parameters, seed) within a process, and a script that
//! runs one `magopt align` per case (studies/reproduce-align.sh) reuses it through these files.
//!
//! A file holds its key (the code fingerprint, the seed and the packing parameters) and every
//! number as its bits, so a loaded packing is the packing `generate` returns, bit for bit. A
//! file whose length, header or key does not match is not used: the packing is regenerated and
//! the file replaced.

use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::Packing;
use crate::models::align::dem::contacts::Container;
use crate::output::atomic::write_atomic;
use crate::Result;

/// First bytes of every file (the layout's version).
const HEADER: &[u8] = b"magopt packing 1\n";

/// The file of `key` in `dir`: the key's FNV-1a hash (the key itself is checked on load).
pub fn path_in(dir: &Path, key: &str) -> PathBuf {
    let hash = key.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    dir.join(format!("{hash:016x}.packing"))
}

/// Bytes of a file holding `particles` particles under `key`.
fn length(key: &str, particles: usize) -> u64 {
    let numbers = 8 * particles + 2 + 1 + 3; // radius, centre, orientation; die; top; steps
    (HEADER.len() + 8 + key.len() + 8 + 8 * numbers + 1) as u64
}

/// Writes `packing` under `key` to `path` atomically.
pub fn save(path: &Path, key: &str, packing: &Packing) -> Result<()> {
    let n = packing.radius.len();
    let mut bytes = Vec::with_capacity(length(key, n) as usize);
    bytes.extend_from_slice(HEADER);
    bytes.extend_from_slice(&(key.len() as u64).to_le_bytes());
    bytes.extend_from_slice(key.as_bytes());
    bytes.extend_from_slice(&(n as u64).to_le_bytes());
    let mut put = |x: f64| bytes.extend_from_slice(&x.to_bits().to_le_bytes());
    packing.radius.iter().for_each(|&r| put(r));
    packing.position.iter().flatten().for_each(|&x| put(x));
    (packing.orientation.iter()).for_each(|q| q.coords.iter().for_each(|&c| put(c)));
    let Container { lx, ly, top } = packing.container;
    [lx, ly, top.unwrap_or(0.0)].into_iter().for_each(&mut put);
    packing
        .steps
        .iter()
        .for_each(|&s| put(f64::from_bits(s as u64)));
    bytes.push(u8::from(top.is_some()));
    write_atomic(path, &bytes)
}

/// The packing of `particles` particles stored under `key` at `path`, or `None` when there is
/// none or it is not a complete file of that key (read only up to the length it must have).
pub fn load(path: &Path, key: &str, particles: usize) -> Option<Packing> {
    let expected = length(key, particles);
    let file = File::open(path).ok()?;
    if file.metadata().ok()?.len() != expected {
        return None;
    }
    let mut bytes = Vec::with_capacity(expected as usize);
    file.take(expected).read_to_end(&mut bytes).ok()?;
    // the length is checked, so every split below is in range
    let (stored_length, rest) = bytes.strip_prefix(HEADER)?.split_at(8);
    let (stored_key, rest) = rest.split_at(key.len());
    let (count, rest) = rest.split_at(8);
    let word = |b: &[u8]| u64::from_le_bytes(b.try_into().expect("8 bytes"));
    if word(stored_length) != key.len() as u64
        || stored_key != key.as_bytes()
        || word(count) != particles as u64
        || rest[rest.len() - 1] > 1
    {
        return None;
    }
    let (numbers, flag) = rest.split_at(rest.len() - 1);
    let mut words = numbers.chunks_exact(8).map(word);
    let mut take = || f64::from_bits(words.next().expect("length checked"));
    let radius = (0..particles).map(|_| take()).collect();
    let position = (0..particles)
        .map(|_| Vector3::new(take(), take(), take()))
        .collect();
    let orientation = (0..particles)
        .map(|_| {
            let [i, j, k, w] = [take(), take(), take(), take()];
            UnitQuaternion::new_unchecked(Quaternion::new(w, i, j, k))
        })
        .collect();
    let [lx, ly, top] = [take(), take(), take()];
    let steps = [0; 3].map(|_| take().to_bits() as usize);
    Some(Packing {
        radius,
        position,
        orientation,
        container: Container {
            lx,
            ly,
            top: (flag[0] == 1).then_some(top),
        },
        steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packing() -> Packing {
        let q = UnitQuaternion::from_euler_angles(0.1, -0.7, 2.3);
        Packing {
            radius: vec![1.0 / 3.0, 0.9],
            position: vec![Vector3::new(0.1, 1e-300, -2.5), Vector3::new(7.0, 8.0, 9.0)],
            orientation: vec![q, UnitQuaternion::identity()],
            container: Container {
                lx: 4.5,
                ly: 5.5,
                top: Some(6.25),
            },
            steps: [3, 5, 1 << 40],
        }
    }

    fn same(a: &Packing, b: &Packing) -> bool {
        let bits = |p: &Packing| -> Vec<u64> {
            let mut v: Vec<u64> = p.radius.iter().map(|x| x.to_bits()).collect();
            v.extend(p.position.iter().flatten().map(|x| x.to_bits()));
            v.extend(
                p.orientation
                    .iter()
                    .flat_map(|q| q.coords.iter().map(|x| x.to_bits())),
            );
            v.extend([p.container.lx, p.container.ly].map(f64::to_bits));
            v
        };
        bits(a) == bits(b) && a.container.top == b.container.top && a.steps == b.steps
    }

    #[test]
    fn a_stored_packing_loads_bit_for_bit_under_its_key_only() {
        let dir = std::env::temp_dir().join(format!("magopt-store-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let key = "align+abc|1|params";
        let path = path_in(&dir, key);
        let mut original = packing();
        save(&path, key, &original).unwrap();
        assert!(same(&load(&path, key, 2).unwrap(), &original));
        assert!(
            load(&path, "align+abd|1|params", 2).is_none(),
            "another key"
        );
        assert!(load(&path, key, 3).is_none(), "another size");
        original.container.top = None;
        save(&path, key, &original).unwrap();
        assert!(same(&load(&path, key, 2).unwrap(), &original));
        // a truncated or damaged file is not used
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        assert!(load(&path, key, 2).is_none());
        let mut damaged = bytes.clone();
        damaged[0] ^= 1;
        std::fs::write(&path, &damaged).unwrap();
        assert!(load(&path, key, 2).is_none());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
