//! LAMMPS `dump custom` text (OVITO, LAMMPS tools): `ITEM: TIME` (s), `ITEM: TIMESTEP`,
//! `ITEM: NUMBER OF ATOMS`, `ITEM: BOX BOUNDS` with boundary flags (`pp` periodic, `ff`
//! fixed; m), `ITEM: ATOMS id type x y z radius vx vy vz mass` (kg) and the extra columns (a vector `v`
//! as `v_x v_y v_z`). Only axis-aligned cells are written (LAMMPS tilted boxes are not).

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::{number, pick_frame, Cell, ParticleFrame, Property};
use crate::{Error, Result};

/// One frame as a LAMMPS dump, `step` being the TIMESTEP value.
///
/// # Errors
/// [`Error::Input`] if the cell is not axis-aligned.
pub fn lammps_dump(frame: &ParticleFrame, step: u64) -> Result<String> {
    let c = &frame.cell;
    if !c.is_aligned() {
        return Err(Error::input("a LAMMPS dump needs an axis-aligned cell"));
    }
    let flags: Vec<&str> = c.pbc.iter().map(|p| if *p { "pp" } else { "ff" }).collect();
    let mut text = format!(
        "ITEM: TIME\n{:?}\nITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{}\nITEM: BOX BOUNDS {}\n",
        frame.time,
        frame.len(),
        flags.join(" ")
    );
    for k in 0..3 {
        let (lo, d) = (c.origin[k], c.vectors[k][k]);
        let _ = writeln!(text, "{lo:?} {:?}", lo + d);
    }
    let _ = writeln!(text, "ITEM: ATOMS {}", header(frame).join(" "));
    for i in 0..frame.len() {
        text.push_str(&row(frame, i));
    }
    Ok(text)
}

/// The ATOMS column names.
fn header(frame: &ParticleFrame) -> Vec<String> {
    let mut names: Vec<String> = [
        "id", "type", "x", "y", "z", "radius", "vx", "vy", "vz", "mass",
    ]
    .map(String::from)
    .to_vec();
    for p in &frame.extra {
        match p.components() {
            1 => names.push(p.name.clone()),
            _ => names.extend(["x", "y", "z"].map(|a| format!("{}_{a}", p.name))),
        }
    }
    names
}

fn row(frame: &ParticleFrame, i: usize) -> String {
    let (p, v) = (frame.position[i], frame.velocity[i]);
    let mut line = format!(
        "{} {} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
        frame.id[i], frame.kind[i], p.x, p.y, p.z, frame.radius[i], v.x, v.y, v.z, frame.mass[i]
    );
    for prop in &frame.extra {
        for k in 0..prop.components() {
            let _ = write!(line, " {:?}", prop.get(i, k));
        }
    }
    line.push('\n');
    line
}

/// Reads the first frame of a dump written by [`lammps_dump`]. The dump carries no species
/// symbols or units: species are [`super::SPECIES`], extra columns have an empty unit.
pub fn read_lammps_dump(text: &str) -> Result<ParticleFrame> {
    let lines: Vec<&str> = text.lines().collect();
    let item = |name: &str| {
        lines
            .iter()
            .position(|l| l.starts_with(&format!("ITEM: {name}")))
            .ok_or_else(|| Error::input(format!("no ITEM: {name}")))
    };
    let at = |k: usize| lines.get(k).copied().unwrap_or("");
    let time = number(at(item("TIME")? + 1))?;
    let n: usize = at(item("NUMBER OF ATOMS")? + 1)
        .trim()
        .parse()
        .map_err(|_| Error::input("bad NUMBER OF ATOMS"))?;
    let b = item("BOX BOUNDS")?;
    let cell = bounds(lines[b], &lines[b + 1..(b + 4).min(lines.len())])?;
    let a = item("ATOMS")?;
    let names: Vec<&str> = lines[a].split_whitespace().skip(2).collect();
    let rows = lines
        .get(a + 1..a + 1 + n)
        .ok_or_else(|| Error::input("LAMMPS dump is cut short"))?;
    let mut frame = ParticleFrame::new(time, cell, vec![1; n]);
    frame.extra = extras(names.get(10..).unwrap_or(&[]), n);
    for (i, r) in rows.iter().enumerate() {
        fill(&mut frame, i, r)?;
    }
    Ok(frame)
}

/// The text of each frame of a dump: every frame starts with the line the first one starts
/// with (`ITEM: TIME` for magopt's dumps, `ITEM: TIMESTEP` for plain LAMMPS ones).
pub fn lammps_frames(text: &str) -> Vec<&str> {
    let Some(marker) = text.lines().next().map(str::trim_end) else {
        return Vec::new();
    };
    let mut starts: Vec<usize> = Vec::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        if line.trim_end() == marker {
            starts.push(offset);
        }
        offset += line.len();
    }
    starts
        .iter()
        .enumerate()
        .map(|(k, &a)| &text[a..starts.get(k + 1).copied().unwrap_or(text.len())])
        .collect()
}

/// Reads frame `index` of a (multi-frame) dump written by [`lammps_dump`]; negative `index`
/// counts from the end, −1 the last frame. See [`read_lammps_dump`].
///
/// # Errors
/// [`Error::Input`] if there is no such frame or it does not parse.
pub fn read_lammps_dump_frame(text: &str, index: isize) -> Result<ParticleFrame> {
    read_lammps_dump(pick_frame(&lammps_frames(text), index)?)
}

/// The cell from the BOX BOUNDS line and its three `lo hi` lines.
fn bounds(line: &str, rows: &[&str]) -> Result<Cell> {
    let flags: Vec<&str> = line.split_whitespace().skip(3).collect();
    if rows.len() != 3 || flags.len() != 3 {
        return Err(Error::input(format!("bad box: '{line}'")));
    }
    let mut lo = Vector3::zeros();
    let mut hi = Vector3::zeros();
    for k in 0..3 {
        let w: Vec<f64> = rows[k]
            .split_whitespace()
            .map(number)
            .collect::<Result<_>>()?;
        (lo[k], hi[k]) = (w[0], w[1]);
    }
    let mut cell = Cell::aligned(lo, hi);
    cell.pbc = [flags[0] == "pp", flags[1] == "pp", flags[2] == "pp"];
    Ok(cell)
}

/// Extra columns from their dump names (`v_x v_y v_z` regroup into a vector `v`).
fn extras(names: &[&str], n: usize) -> Vec<Property> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < names.len() {
        let stem = names[k].strip_suffix("_x");
        let vector = stem.is_some_and(|s| {
            names.get(k + 1) == Some(&format!("{s}_y").as_str())
                && names.get(k + 2) == Some(&format!("{s}_z").as_str())
        });
        if let (true, Some(s)) = (vector, stem) {
            out.push(Property::vector(s, "", vec![Vector3::zeros(); n]));
            k += 3;
        } else {
            out.push(Property::scalar(names[k], "", vec![0.0; n]));
            k += 1;
        }
    }
    out
}

fn fill(frame: &mut ParticleFrame, i: usize, row: &str) -> Result<()> {
    let w: Vec<&str> = row.split_whitespace().collect();
    let int = |s: &str| {
        s.parse::<u64>()
            .map_err(|_| Error::input(format!("bad integer '{s}'")))
    };
    if w.len() < 9 {
        return Err(Error::input(format!("short ATOMS row: '{row}'")));
    }
    frame.id[i] = int(w[0])?;
    frame.kind[i] = int(w[1])? as u32;
    let x: Vec<f64> = w[2..].iter().map(|s| number(s)).collect::<Result<_>>()?;
    super::fill_numbers(frame, i, &x)
}
