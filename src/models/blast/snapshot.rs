//! Snapshot writers (sinks): extended XYZ (OVITO, ASE) and Parquet, one file each per time.

use std::fmt::Write as _;
use std::path::Path;

use super::cloud::Cloud;
use crate::output::atomic::write_atomic;
use crate::output::table::{write_parquet, ColumnData, Table};
use crate::Result;

/// Extended XYZ text of a cloud at time `time` (s): species, position (m), velocity (m/s),
/// radius (m), charge per mass (C/kg), spin (rad/s).
pub fn extended_xyz(cloud: &Cloud, time: f64) -> String {
    let mut text = format!(
        "{}\nProperties=species:S:1:pos:R:3:velo:R:3:radius:R:1:charge_per_mass:R:1:spin:R:3 Time={time:e} pbc=\"F F F\"\n",
        cloud.len()
    );
    for i in 0..cloud.len() {
        let (r, v, w) = (cloud.positions[i], cloud.velocities[i], cloud.spins[i]);
        let _ = writeln!(
            text,
            "P {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}",
            r.x, r.y, r.z, v.x, v.y, v.z, cloud.radius, cloud.charge_per_mass[i], w.x, w.y, w.z
        );
    }
    text
}

/// The same snapshot as a table (one row per particle).
pub fn table(cloud: &Cloud) -> Table {
    let col = |f: &dyn Fn(usize) -> f64| ColumnData::F64((0..cloud.len()).map(f).collect());
    Table::new()
        .with("id", ColumnData::U64((0..cloud.len() as u64).collect()))
        .with("x_m", col(&|i| cloud.positions[i].x))
        .with("y_m", col(&|i| cloud.positions[i].y))
        .with("z_m", col(&|i| cloud.positions[i].z))
        .with("vx_m_per_s", col(&|i| cloud.velocities[i].x))
        .with("vy_m_per_s", col(&|i| cloud.velocities[i].y))
        .with("vz_m_per_s", col(&|i| cloud.velocities[i].z))
        .with("radius_m", col(&|_| cloud.radius))
        .with(
            "charge_per_mass_C_per_kg",
            col(&|i| cloud.charge_per_mass[i]),
        )
}

/// Writes `snapshot_<k>_t<time>s.xyz` and `.parquet` into `dir` (which must exist).
pub fn write(dir: &Path, k: usize, time: f64, cloud: &Cloud) -> Result<()> {
    let stem = format!("snapshot_{k:03}_t{time:.4}s");
    write_atomic(
        &dir.join(format!("{stem}.xyz")),
        extended_xyz(cloud, time).as_bytes(),
    )?;
    write_parquet(&dir.join(format!("{stem}.parquet")), &table(cloud))
}
