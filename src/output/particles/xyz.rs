//! Extended XYZ (OVITO, ASE): one frame is a count line, a key=value comment line with
//! `Lattice`, `Origin`, `Properties`, `Time` (s), `pbc` and `units` (the SI unit of every
//! extra column), then one row per particle. Floats are printed with `{:?}` (shortest text
//! that reads back to the same bits). A multi-frame file is frames one after the other.

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::{fill_numbers, number, pick_frame, Cell, ParticleFrame, Property};
use crate::{Error, Result};

/// The fixed leading columns of `Properties`. `type` comes before `species`: OVITO maps both to
/// its Particle Type and keeps the first, and the numeric type is the one that tells species
/// apart (every species symbol is `X`).
const FIXED: &str = "type:I:1:species:S:1:pos:R:3:radius:R:1:velo:R:3:masses:R:1:momenta:R:3";

/// One frame as extended XYZ text.
pub fn extended_xyz(frame: &ParticleFrame) -> String {
    let mut text = format!("{}\n{}\n", frame.len(), comment(frame));
    for i in 0..frame.len() {
        text.push_str(&row(frame, i));
    }
    text
}

/// The comment line of a frame.
fn comment(frame: &ParticleFrame) -> String {
    let c = &frame.cell;
    let v = |x: &Vector3<f64>| format!("{:?} {:?} {:?}", x.x, x.y, x.z);
    let lattice = c.vectors.iter().map(v).collect::<Vec<_>>().join(" ");
    let flag = |p: bool| if p { "T" } else { "F" };
    let pbc: Vec<&str> = c.pbc.iter().map(|p| flag(*p)).collect();
    let mut properties = String::from(FIXED);
    let mut units = String::from("pos:m radius:m velo:m_per_s masses:kg momenta:kg_m_per_s");
    for p in &frame.extra {
        let _ = write!(properties, ":{}:R:{}", p.name, p.components());
        let _ = write!(units, " {}:{}", p.name, p.unit);
    }
    format!(
        "Lattice=\"{lattice}\" Origin=\"{}\" Properties={properties} Time={:?} pbc=\"{}\" units=\"{units}\"",
        v(&c.origin),
        frame.time,
        pbc.join(" ")
    )
}

/// The text row of particle `i`.
fn row(frame: &ParticleFrame, i: usize) -> String {
    let (p, v, m) = (frame.position[i], frame.velocity[i], frame.mass[i]);
    let q = v * m;
    let mut line = format!(
        "{} {} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {m:?} {:?} {:?} {:?}",
        frame.kind[i],
        frame.species[i],
        p.x,
        p.y,
        p.z,
        frame.radius[i],
        v.x,
        v.y,
        v.z,
        q.x,
        q.y,
        q.z
    );
    for prop in &frame.extra {
        for k in 0..prop.components() {
            let _ = write!(line, " {:?}", prop.get(i, k));
        }
    }
    line.push('\n');
    line
}

/// Reads frame `index` of an extended XYZ text written by [`extended_xyz`] (ids are the row
/// numbers, 1-based; negative `index` counts from the end, −1 the last frame).
pub fn read_xyz(text: &str, index: isize) -> Result<ParticleFrame> {
    let lines: Vec<&str> = text.lines().collect();
    let start = *pick_frame(&frame_starts(&lines)?, index)?;
    let n = count(lines[start])?;
    let rows = lines
        .get(start + 2..start + 2 + n)
        .ok_or_else(|| Error::input("extended XYZ frame is cut short"))?;
    parse_frame(lines[start + 1], rows)
}

/// Number of frames in an extended XYZ text (counted from the particle-count lines).
///
/// # Errors
/// [`Error::Input`] if a frame's first line is not a particle count.
pub fn xyz_frame_count(text: &str) -> Result<usize> {
    let lines: Vec<&str> = text.lines().collect();
    frame_starts(&lines).map(|s| s.len())
}

/// The first line of every frame.
fn frame_starts(lines: &[&str]) -> Result<Vec<usize>> {
    let mut starts = Vec::new();
    let mut at = 0;
    while at < lines.len() && !lines[at].trim().is_empty() {
        starts.push(at);
        // saturating: a count near usize::MAX in a corrupt file ends the scan (that frame is
        // then cut short) instead of wrapping `at` back into the text
        at = at.saturating_add(2).saturating_add(count(lines[at])?);
    }
    Ok(starts)
}

fn count(line: &str) -> Result<usize> {
    line.trim()
        .parse()
        .map_err(|_| Error::input(format!("not a particle count: '{line}'")))
}

/// Splits a comment line into key=value pairs (values may be double-quoted).
fn key_values(line: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = line.trim();
    while let Some(eq) = rest.find('=') {
        let key = rest[..eq].trim().to_string();
        let after = &rest[eq + 1..];
        let (value, tail) = match after.strip_prefix('"') {
            Some(q) => q.split_once('"').unwrap_or((q, "")),
            None => after.split_once(' ').unwrap_or((after, "")),
        };
        out.push((key, value.to_string()));
        rest = tail.trim_start();
    }
    out
}

/// Three floats from a space-separated text.
fn floats(text: &str) -> Result<Vec<f64>> {
    text.split_whitespace().map(number).collect()
}

fn parse_frame(comment: &str, rows: &[&str]) -> Result<ParticleFrame> {
    let kv = key_values(comment);
    let get = |k: &str| kv.iter().find(|(key, _)| key == k).map(|(_, v)| v.as_str());
    let need = |k: &str| get(k).ok_or_else(|| Error::input(format!("no {k}= in the comment")));
    let l = floats(need("Lattice")?)?;
    let o = floats(get("Origin").unwrap_or("0 0 0"))?;
    if l.len() != 9 || o.len() != 3 {
        return Err(Error::input("Lattice needs 9 numbers and Origin 3"));
    }
    let vec3 = |s: &[f64]| Vector3::new(s[0], s[1], s[2]);
    let pbc: Vec<bool> = need("pbc")?.split_whitespace().map(|f| f == "T").collect();
    let cell = Cell {
        origin: vec3(&o),
        vectors: [vec3(&l[0..3]), vec3(&l[3..6]), vec3(&l[6..9])],
        pbc: [
            pbc.first() == Some(&true),
            pbc.get(1) == Some(&true),
            pbc.get(2) == Some(&true),
        ],
    };
    let units = units(get("units").unwrap_or(""));
    let columns = properties(need("Properties")?)?;
    let mut frame = ParticleFrame::new(number(need("Time")?)?, cell, vec![1; rows.len()]);
    for (name, width) in columns.iter().skip(7) {
        let unit = units.iter().find(|(n, _)| n == name).map_or("", |(_, u)| u);
        frame.extra.push(empty(name, unit, *width, rows.len())?);
    }
    for (i, row) in rows.iter().enumerate() {
        fill(&mut frame, i, row)?;
    }
    Ok(frame)
}

/// `name:unit` pairs of the `units` key.
fn units(text: &str) -> Vec<(String, String)> {
    let pair = |w: &str| {
        w.split_once(':')
            .map(|(a, b)| (a.to_string(), b.to_string()))
    };
    text.split_whitespace().filter_map(pair).collect()
}

/// The (name, width) list of `Properties`, checked to start with the fixed columns.
fn properties(text: &str) -> Result<Vec<(String, usize)>> {
    let parts: Vec<&str> = text.split(':').collect();
    if !parts.len().is_multiple_of(3) {
        return Err(Error::input(format!("bad Properties: '{text}'")));
    }
    let columns: Vec<(String, usize)> = parts
        .chunks(3)
        .map(|c| Ok((c[0].to_string(), c[2].parse().map_err(|_| bad(text))?)))
        .collect::<Result<_>>()?;
    let fixed: Vec<String> = FIXED.split(':').map(String::from).collect();
    if parts.len() < fixed.len() || parts[..fixed.len()] != fixed[..] {
        return Err(bad(text));
    }
    Ok(columns)
}

fn bad(text: &str) -> Error {
    Error::input(format!("Properties must start with {FIXED}, got '{text}'"))
}

/// An extra column of `n` zeros.
fn empty(name: &str, unit: &str, width: usize, n: usize) -> Result<Property> {
    match width {
        1 => Ok(Property::scalar(name, unit, vec![0.0; n])),
        3 => Ok(Property::vector(name, unit, vec![Vector3::zeros(); n])),
        _ => Err(Error::input(format!("column {name}: {width} components"))),
    }
}

/// Fills particle `i` from its text row.
fn fill(frame: &mut ParticleFrame, i: usize, row: &str) -> Result<()> {
    let w: Vec<&str> = row.split_whitespace().collect();
    if w.len() < 2 {
        return Err(Error::input(format!("short row: '{row}'")));
    }
    frame.kind[i] = w[0]
        .parse()
        .map_err(|_| Error::input(format!("bad type '{}'", w[0])))?;
    frame.species[i] = w[1].to_string();
    let mut x: Vec<f64> = w[2..].iter().map(|s| number(s)).collect::<Result<_>>()?;
    if x.len() < 11 {
        return Err(Error::input(format!("short row: '{row}'")));
    }
    x.drain(8..11); // momenta: derived from velo and masses
    fill_numbers(frame, i, &x)
}
