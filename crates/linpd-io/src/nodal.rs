//! Nodal forces and prescribed displacements by node index, as CSV: what `linpd coarsen` writes
//! beside each level's moduli (`level-<m>.forces.csv`, `level-<m>.prescribed.csv`) and a scene
//! reads back (`{"type": "nodal", "file": ...}` loads, `{"file": ...}` constraints).
//!
//! * forces: header `node,f_x[,f_y[,f_z]]` (one force column per dimension), one line per
//!   loaded node;
//! * prescribed: header `node,component,value` (`component` 0-based: 0 = x), one line per
//!   prescribed DOF.
//!
//! Node indices are 0-based in the scene's node order. Values are written in Rust's shortest
//! round-trip form, so they read back bit for bit. `#` starts a comment line. Errors name the
//! file and the line: a wrong header, a node out of range, a repeated node (or DOF), a value that
//! is not a finite number.

use crate::cloud::{open_csv, CsvErrors};
use crate::IoError;
use std::collections::HashSet;
use std::fmt::Write as _;
use std::path::Path;

const AXES: [&str; 3] = ["f_x", "f_y", "f_z"];

/// Writes the nonzero nodal forces `f` (`dim` per node) to `path`.
pub fn write_forces(path: &Path, dim: usize, f: &[f64]) -> Result<(), IoError> {
    let mut s = String::from("node");
    AXES[..dim].iter().for_each(|a| s.push_str(&format!(",{a}")));
    s.push('\n');
    for (i, fi) in f.chunks(dim).enumerate() {
        if fi.iter().any(|&t| t != 0.0) {
            let _ = write!(s, "{i}");
            fi.iter().for_each(|t| {
                let _ = write!(s, ",{t:?}");
            });
            s.push('\n');
        }
    }
    std::fs::write(path, s).map_err(IoError::os(path))
}

/// Writes prescribed DOFs `(node, component, value)` to `path`.
pub fn write_prescribed(path: &Path, entries: &[(usize, usize, f64)]) -> Result<(), IoError> {
    let mut s = String::from("node,component,value\n");
    for (n, a, v) in entries {
        let _ = writeln!(s, "{n},{a},{v:?}");
    }
    std::fs::write(path, s).map_err(IoError::os(path))
}

/// Reads nodal forces for `n_nodes` nodes of dimension `dim`: `(node, force, line)` per line.
pub fn read_forces(path: &Path, dim: usize, n_nodes: usize) -> Result<Vec<(usize, Vec<f64>, u64)>, IoError> {
    let mut expected = vec!["node".to_string()];
    expected.extend(AXES[..dim].iter().map(|a| a.to_string()));
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    read_rows(path, &expected, |row, line, err| {
        let node = row.node(n_nodes)?;
        if !seen.insert(node) {
            return Err(err.at(line, format!("node {node} is listed twice")));
        }
        let f = (0..dim).map(|a| row.number(a + 1, AXES[a])).collect::<Result<Vec<_>, _>>()?;
        out.push((node, f, line));
        Ok(())
    })?;
    Ok(out)
}

/// Reads prescribed DOFs for `n_nodes` nodes of dimension `dim`: `(node, component, value,
/// line)` per line.
pub fn read_prescribed(path: &Path, dim: usize, n_nodes: usize) -> Result<Vec<(usize, usize, f64, u64)>, IoError> {
    let expected: Vec<String> = ["node", "component", "value"].iter().map(|s| s.to_string()).collect();
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    read_rows(path, &expected, |row, line, err| {
        let node = row.node(n_nodes)?;
        let a = row.index(1, "component", dim)?;
        if !seen.insert((node, a)) {
            return Err(err.at(line, format!("node {node} component {a} is listed twice")));
        }
        out.push((node, a, row.number(2, "value")?, line));
        Ok(())
    })?;
    Ok(out)
}

/// One data line.
struct Row<'a> {
    record: &'a csv::StringRecord,
    line: u64,
    err: &'a CsvErrors,
}

impl Row<'_> {
    fn number(&self, k: usize, name: &str) -> Result<f64, IoError> {
        let s = &self.record[k];
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err.at(self.line, format!("{name} = {s:?} is not a finite number"))),
        }
    }
    fn index(&self, k: usize, name: &str, bound: usize) -> Result<usize, IoError> {
        let s = &self.record[k];
        match s.parse::<usize>() {
            Ok(v) if v < bound => Ok(v),
            _ => Err(self.err.at(self.line, format!("{name} = {s:?} is not an index below {bound}"))),
        }
    }
    fn node(&self, n_nodes: usize) -> Result<usize, IoError> {
        self.index(0, "node", n_nodes)
    }
}

/// Reads `path` with the header `expected`, calling `each` on every data line.
fn read_rows(
    path: &Path,
    expected: &[String],
    mut each: impl FnMut(&Row, u64, &CsvErrors) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let err = CsvErrors { path: path.display().to_string() };
    let mut reader = open_csv(path, &err)?;
    let headers = reader.headers().map_err(|e| err.at(1, format!("unreadable header ({e})")))?.clone();
    let got: Vec<&str> = headers.iter().collect();
    if got != expected.iter().map(String::as_str).collect::<Vec<_>>() {
        return Err(err.at(1, format!("header {:?}, expected {:?}", got.join(","), expected.join(","))));
    }
    let mut record = csv::StringRecord::new();
    loop {
        let more = reader.read_record(&mut record).map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            err.at(line, format!("unreadable ({e})"))
        })?;
        if !more {
            return Ok(());
        }
        let line = record.position().map_or(0, |p| p.line());
        if record.len() != expected.len() {
            return Err(err.at(line, format!("{} fields, the header has {}", record.len(), expected.len())));
        }
        each(&Row { record: &record, line, err: &err }, line, &err)?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("linpd-nodal-{}-{name}", std::process::id()))
    }

    #[test]
    fn forces_and_prescribed_values_read_back_bit_for_bit() {
        let f = vec![0.0, 0.0, 1.0 / 3.0, -2.5e-300, 0.0, 7.0];
        let p = temp("f.csv");
        write_forces(&p, 2, &f).unwrap();
        let back = read_forces(&p, 2, 3).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!((back[0].0, back[0].1.clone()), (1, vec![1.0 / 3.0, -2.5e-300]));
        assert_eq!((back[1].0, back[1].1.clone()), (2, vec![0.0, 7.0]));
        let q = temp("p.csv");
        write_prescribed(&q, &[(0, 1, 0.1 + 0.2), (4, 0, -1.0)]).unwrap();
        let back = read_prescribed(&q, 2, 5).unwrap();
        assert_eq!(back.iter().map(|e| (e.0, e.1, e.2)).collect::<Vec<_>>(), vec![(0, 1, 0.1 + 0.2), (4, 0, -1.0)]);
    }

    #[test]
    fn bad_lines_are_named() {
        let cases = [
            ("node,f_x\n0,1\n", 2, "line 1: header"),
            ("node,f_x\n0,1\n5,1\n", 1, "line 3: node = \"5\" is not an index below 3"),
            ("node,f_x\n0,1\n0,2\n", 1, "line 3: node 0 is listed twice"),
            ("node,f_x\n0,nan\n", 1, "line 2: f_x = \"nan\" is not a finite number"),
            ("node,f_x\n0\n", 1, "line 2: 1 fields"),
        ];
        for (k, (text, dim, want)) in cases.iter().enumerate() {
            let p = temp(&format!("bad{k}.csv"));
            std::fs::write(&p, text).unwrap();
            let e = read_forces(&p, *dim, 3).unwrap_err().to_string();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        let p = temp("badp.csv");
        std::fs::write(&p, "node,component,value\n0,2,1.0\n").unwrap();
        let e = read_prescribed(&p, 2, 3).unwrap_err().to_string();
        assert!(e.contains("line 2: component = \"2\" is not an index below 2"), "{e}");
    }
}
