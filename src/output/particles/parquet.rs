//! The Parquet table of a frame (polars): one row per particle, column names with SI unit
//! suffixes: `time_s`, `id`, `species`, `type`, `x_m`, `y_m`, `z_m`, `radius_m`,
//! `vx_m_per_s`, `vy_m_per_s`, `vz_m_per_s`, `mass_kg`, then each extra scalar `s` as `s_<unit>` and each
//! extra vector `v` as `v_x_<unit>`, `v_y_<unit>`, `v_z_<unit>` (dimensionless ones, unit `1`,
//! without a suffix: `cos_theta`, `easy_axis_x`). Every physical column also carries its unit in
//! the Parquet field metadata (`unit`: `s`, `m`, `m/s`, `kg`, …), and the file's key-value
//! metadata `magopt.cell` holds the cell (origin, lattice vectors a, b, c, pbc) as JSON, so
//! [`read_particle_table`] reads a frame back whole.

use std::path::Path;

use nalgebra::Vector3;

use super::{Cell, ParticleFrame, Property, Values};
use crate::output::table::{
    read_parquet_with_metadata, write_parquet_with, ColumnData as C, Table,
};
use crate::{Error, Result};

/// Key of the cell in the Parquet key-value metadata.
const CELL_KEY: &str = "magopt.cell";

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
                let name = format!("{}{}", p.name, suffix(&p.unit));
                t.push_unit(&name, C::F64(v.clone()), &unit);
            }
            Values::Vector(v) => {
                let names = ["x", "y", "z"].map(|a| format!("{}_{a}{}", p.name, suffix(&p.unit)));
                push_vector(&mut t, &names.each_ref().map(String::as_str), v, &unit);
            }
        }
    }
    t
}

/// The column-name suffix of a unit: `_<unit>`, none for dimensionless (`1`).
fn suffix(unit: &str) -> String {
    if unit == "1" {
        String::new()
    } else {
        format!("_{unit}")
    }
}

/// Writes the frame's table with its cell, atomically.
pub fn write_particle_table(path: &Path, frame: &ParticleFrame) -> Result<()> {
    let c = &frame.cell;
    let cell = serde_json::json!({
        "origin": c.origin.as_slice(),
        "vectors": c.vectors.iter().map(|v| v.as_slice().to_vec()).collect::<Vec<_>>(),
        "pbc": c.pbc,
    });
    write_parquet_with(path, &table(frame), &[(CELL_KEY.into(), cell.to_string())])
}

/// Reads a file written by [`write_particle_table`].
pub fn read_particle_table(path: &Path) -> Result<ParticleFrame> {
    let (t, metadata) = read_parquet_with_metadata(path)?;
    let bad = |what: &str| Error::input(format!("{}: {what}", path.display()));
    let cell = metadata
        .iter()
        .find(|(k, _)| k == CELL_KEY)
        .and_then(|(_, v)| serde_json::from_str::<serde_json::Value>(v).ok())
        .and_then(|v| cell_of(&v))
        .ok_or_else(|| bad("no magopt.cell metadata (not a magopt particle table)"))?;
    let floats = |name: &str| match t.column(name) {
        Some(C::F64(v)) => Ok(v.clone()),
        _ => Err(bad(&format!("no float column '{name}'"))),
    };
    let vectors = |names: [&str; 3]| -> Result<Vec<Vector3<f64>>> {
        let [x, y, z] = [floats(names[0])?, floats(names[1])?, floats(names[2])?];
        Ok((0..x.len())
            .map(|i| Vector3::new(x[i], y[i], z[i]))
            .collect())
    };
    let kind: Vec<u32> = match t.column("type") {
        Some(C::I64(v)) => v.iter().map(|k| *k as u32).collect(),
        _ => return Err(bad("no integer column 'type'")),
    };
    let time = floats("time_s")?.first().copied().unwrap_or(0.0);
    let mut frame = ParticleFrame::new(time, cell, kind);
    if let Some(C::U64(id)) = t.column("id") {
        frame.id = id.clone();
    }
    if let Some(C::Str(species)) = t.column("species") {
        frame.species = species.clone();
    }
    frame.position = vectors(["x_m", "y_m", "z_m"])?;
    frame.radius = floats("radius_m")?;
    frame.velocity = vectors(["vx_m_per_s", "vy_m_per_s", "vz_m_per_s"])?;
    frame.mass = floats("mass_kg")?;
    let fixed = 12; // time, id, species, type, position, radius, velocity, mass
    let rest: Vec<&str> = t.columns[fixed.min(t.columns.len())..]
        .iter()
        .map(|c| c.name.as_str())
        .collect();
    let mut k = 0;
    while k < rest.len() {
        let unit = t.unit(rest[k]).unwrap_or("1");
        let tail = suffix(&unit.replace('/', "_per_").replace(' ', "_"));
        let base = rest[k].strip_suffix(&tail).unwrap_or(rest[k]);
        let unit = if tail.is_empty() {
            "1".to_string()
        } else {
            tail[1..].to_string()
        };
        let vector = base.strip_suffix("_x").filter(|name| {
            let follow =
                |j: usize, a: &str| rest.get(k + j) == Some(&&*format!("{name}_{a}{tail}"));
            follow(1, "y") && follow(2, "z")
        });
        if let Some(name) = vector {
            let names = ["x", "y", "z"].map(|a| format!("{name}_{a}{tail}"));
            let v = vectors(names.each_ref().map(String::as_str))?;
            frame.extra.push(Property::vector(name, &unit, v));
            k += 3;
        } else {
            frame
                .extra
                .push(Property::scalar(base, &unit, floats(rest[k])?));
            k += 1;
        }
    }
    Ok(frame)
}

/// The cell from its JSON form.
fn cell_of(v: &serde_json::Value) -> Option<Cell> {
    let vector = |v: &serde_json::Value| -> Option<Vector3<f64>> {
        let x: Vec<f64> = v.as_array()?.iter().filter_map(|x| x.as_f64()).collect();
        (x.len() == 3).then(|| Vector3::new(x[0], x[1], x[2]))
    };
    let vectors = v["vectors"].as_array()?;
    let pbc: Vec<bool> = v["pbc"]
        .as_array()?
        .iter()
        .filter_map(|b| b.as_bool())
        .collect();
    Some(Cell {
        origin: vector(&v["origin"])?,
        vectors: [
            vector(vectors.first()?)?,
            vector(vectors.get(1)?)?,
            vector(vectors.get(2)?)?,
        ],
        pbc: [*pbc.first()?, *pbc.get(1)?, *pbc.get(2)?],
    })
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
