//! The height-map file: a CSV grid of column heights.
//!
//! ```text
//! # Lines starting with '#' are comments; blank lines are skipped.
//! # One line per row of cells, values separated by commas, heights in mm.
//! # The first row is the one at the smallest Y; values go in +X.
//! 0.0, 0.0, 0.0, -2.5
//! 0.0, 0.0, -2.5, -2.5
//! ```
//!
//! Every row must have as many values as the first; every value must be a finite number in
//! `bottom ..= bottom + 1000` mm (the stock bottom comes from `stock.toml`). Where the file's
//! cells sit (corner, pitch) is said in `stock.toml` (see [`crate::spec`]). Errors name the
//! file, the line and the value's column in its row.

use std::path::Path;

use crate::error::StockError;

/// The highest a column may stand above the stock bottom, mm.
pub const MAX_COLUMN_MM: f64 = 1000.0;

/// The grid of a height-map file.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightGrid {
    /// Values per row (cells along X).
    pub cols: usize,
    /// Rows (cells along Y).
    pub rows: usize,
    /// Heights, row by row from the smallest Y (`[j·cols + i]`), mm.
    pub heights: Vec<f32>,
}

/// Read the height-map file `path` for a stock whose bottom is at `bottom_mm` (mm).
pub fn read_height_map(path: &Path, bottom_mm: f64) -> Result<HeightGrid, StockError> {
    let text = std::fs::read_to_string(path).map_err(|e| StockError::HeightMap {
        file: path.to_path_buf(),
        line: 0,
        column: 0,
        message: format!("cannot read: {e}"),
    })?;
    parse_height_map(path, &text, bottom_mm)
}

/// Parse height-map text that came from `path` (used in errors only).
pub fn parse_height_map(path: &Path, text: &str, bottom_mm: f64) -> Result<HeightGrid, StockError> {
    let err = |line: u64, column: usize, message: String| StockError::HeightMap {
        file: path.to_path_buf(),
        line,
        column,
        message,
    };
    // Read by hand, not with the `csv` crate: its line numbers leave out blank and comment
    // lines, and an error must name the line as an editor shows it. The format has no
    // quoting, so a line is split at its commas.
    let (lo, hi) = (bottom_mm, bottom_mm + MAX_COLUMN_MM);
    let mut cols = 0;
    let mut rows = 0;
    let mut heights = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let line = index as u64 + 1;
        let body = raw.trim();
        if body.is_empty() || body.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = body.split(',').map(str::trim).collect();
        if rows == 0 {
            cols = fields.len();
        } else if fields.len() != cols {
            return Err(err(
                line,
                0,
                format!(
                    "row has {} values, the first row has {cols}: every row must have {cols}",
                    fields.len()
                ),
            ));
        }
        for (k, field) in fields.iter().enumerate() {
            let v: f64 = field.parse().map_err(|_| {
                err(
                    line,
                    k + 1,
                    format!("`{field}` is not a height in mm: allowed {lo} ..= {hi}"),
                )
            })?;
            if !(v.is_finite() && v >= lo && v <= hi) {
                return Err(err(
                    line,
                    k + 1,
                    format!(
                        "height {field} is out of range: allowed {lo} ..= {hi} \
                         (stock bottom_mm ..= bottom_mm + {MAX_COLUMN_MM})"
                    ),
                ));
            }
            heights.push(v as f32);
        }
        rows += 1;
    }
    if rows == 0 || cols == 0 {
        return Err(err(0, 0, "no rows of heights".to_string()));
    }
    Ok(HeightGrid {
        cols,
        rows,
        heights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_rows_and_names_the_line_of_a_bad_value() {
        let p = Path::new("map.csv");
        let g = parse_height_map(p, "# top\n0, 0, -1\n\n-1,-1,-2\n", -10.0).expect("valid");
        assert_eq!((g.cols, g.rows), (3, 2));
        assert_eq!(g.heights, vec![0.0, 0.0, -1.0, -1.0, -1.0, -2.0]);
        let e = parse_height_map(p, "0,0\n0,x\n", -10.0).expect_err("x");
        assert_eq!(
            e.to_string(),
            "map.csv:2:2: `x` is not a height in mm: allowed -10 ..= 990"
        );
        let e = parse_height_map(p, "0,0\n# c\n0,-11\n", -10.0).expect_err("below bottom");
        assert!(
            e.to_string()
                .starts_with("map.csv:3:2: height -11 is out of range: allowed -10 ..= 990"),
            "{e}"
        );
        let e = parse_height_map(p, "0,0\n0,0,0\n", -10.0).expect_err("ragged");
        assert!(
            e.to_string().starts_with("map.csv:2: row has 3 values"),
            "{e}"
        );
        let e = parse_height_map(p, "# nothing\n", -10.0).expect_err("empty");
        assert!(e.to_string().contains("no rows"), "{e}");
    }
}
