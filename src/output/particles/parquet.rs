//! The Parquet table of a frame (polars): one row per particle, column names with SI unit
//! suffixes: `time_s`, `id`, `species`, `type`, `x_m`, `y_m`, `z_m`, `radius_m`,
//! `vx_m_per_s`, `vy_m_per_s`, `vz_m_per_s`, `mass_kg`, then each extra scalar `s` as `s_<unit>` and each
//! extra vector `v` as `v_x_<unit>`, `v_y_<unit>`, `v_z_<unit>`. Every physical column also
//! carries its unit in the Parquet field metadata (`unit`: `s`, `m`, `m/s`, `kg`, …).

use nalgebra::Vector3;

use super::{ParticleFrame, Values};
use crate::output::table::{ColumnData as C, Table};

/// The per-particle table of a frame.
pub fn table(frame: &ParticleFrame) -> Table {
    let n = frame.len();
    let mut t = Table::new()
        .with_unit("time_s", C::F64(vec![frame.time; n]), "s")
        .with("id", C::U64(frame.id.clone()))
        .with("species", C::Str(frame.species.clone()))
        .with(
            "type",
            C::I64(frame.kind.iter().map(|k| *k as i64).collect()),
        );
    push_vector(&mut t, &["x_m", "y_m", "z_m"], &frame.position, "m");
    t.push_unit("radius_m", C::F64(frame.radius.clone()), "m");
    let v = ["vx_m_per_s", "vy_m_per_s", "vz_m_per_s"];
    push_vector(&mut t, &v, &frame.velocity, "m/s");
    t.push_unit("mass_kg", C::F64(frame.mass.clone()), "kg");
    for p in &frame.extra {
        let unit = readable(&p.unit);
        match &p.values {
            Values::Scalar(v) => {
                let name = format!("{}_{}", p.name, p.unit);
                t.push_unit(&name, C::F64(v.clone()), &unit);
            }
            Values::Vector(v) => {
                let names = ["x", "y", "z"].map(|a| format!("{}_{a}_{}", p.name, p.unit));
                push_vector(&mut t, &names.each_ref().map(String::as_str), v, &unit);
            }
        }
    }
    t
}

/// A unit as a name suffix (`C_per_kg`, `A_m2`) in the usual notation (`C/kg`, `A m2`).
fn readable(suffix: &str) -> String {
    suffix.replace("_per_", "/").replace('_', " ")
}

fn push_vector(t: &mut Table, names: &[&str; 3], values: &[Vector3<f64>], unit: &str) {
    for (k, name) in names.iter().enumerate() {
        t.push_unit(name, C::F64(values.iter().map(|v| v[k]).collect()), unit);
    }
}
