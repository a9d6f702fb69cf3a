//! `stock.toml`: the stock as a box or as a height-map file, and the cell size.
//!
//! ```toml
//! cell_mm = 0.25                  # optional, default 0.25; 0.01 ..= 10
//!
//! [box]                           # either a box ...
//! min_mm = [0.0, 0.0, -30.0]      # x0, y0, z0 (z0: stock bottom)
//! max_mm = [200.0, 200.0, 0.0]    # x1, y1, z1 (z1: top)
//!
//! # [height_map]                  # ... or a height map (exactly one of the two)
//! # file = "part.csv"             # relative to this file (format: crate::heightmap)
//! # corner_mm = [0.0, 0.0]        # x, y of the outer corner of the file's first value
//! # pitch_mm = 1.0                # side of the file's cells; 0.01 ..= 100
//! # bottom_mm = -30.0             # stock bottom z0
//! ```
//!
//! Unknown keys are refused; every error names the file, the key and the allowed range
//! (`acc_config` conventions). A height map is resampled onto the cells of `cell_mm` by
//! nearest value (each cell takes the file value under its centre).

use std::path::{Path, PathBuf};
use std::str::FromStr;

use acc_config::{ConfigError, KeyRange, RangeError};
use serde::Deserialize;

use crate::error::{in_range, StockError};
use crate::heightmap::read_height_map;
use crate::zmap::ZMap;

/// A `stock.toml` file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StockFile {
    /// Cell size c, mm (default [`ZMap::DEFAULT_CELL_MM`] = 0.25; range
    /// [`ZMap::CELL_RANGE_MM`]).
    #[serde(default = "default_cell")]
    pub cell_mm: f64,
    /// `[box]`: a box stock.
    #[serde(rename = "box", default)]
    pub stock_box: Option<BoxSpec>,
    /// `[height_map]`: a stock from a height-map file.
    #[serde(default)]
    pub height_map: Option<HeightMapSpec>,
}

fn default_cell() -> f64 {
    ZMap::DEFAULT_CELL_MM
}

/// `[box]`: the stock `[x0, x1] × [y0, y1] × [z0, z1]`, mm.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// `[x0, y0, z0]`, mm (z0 is the stock bottom); each in ±1e5.
    pub min_mm: [f64; 3],
    /// `[x1, y1, z1]`, mm (z1 is the top); each above its `min_mm`.
    pub max_mm: [f64; 3],
}

/// `[height_map]`: the stock from a height-map file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightMapSpec {
    /// The height-map file, relative to the `stock.toml` that names it.
    pub file: PathBuf,
    /// Outer corner `[x, y]` of the file's first value (smallest X and Y), mm.
    pub corner_mm: [f64; 2],
    /// Side of the file's cells, mm; 0.01 ..= 100.
    pub pitch_mm: f64,
    /// Stock bottom z0, mm; every height must lie in `bottom_mm ..= bottom_mm + 1000`.
    pub bottom_mm: f64,
}

/// The ranges of the numeric keys, shown when a value does not even deserialize.
const RANGES: &[KeyRange] = &[
    KeyRange::new("cell_mm", "0.01 ..= 10"),
    KeyRange::new("height_map.pitch_mm", "0.01 ..= 100"),
    KeyRange::new("height_map.bottom_mm", "-1e5 ..= 1e5"),
];

impl BoxSpec {
    /// The box as a map of cells of `cell_mm` (mm).
    pub fn zmap(&self, cell_mm: f64) -> Result<ZMap, StockError> {
        ZMap::from_box(self.min_mm, self.max_mm, cell_mm)
    }
}

impl FromStr for BoxSpec {
    type Err = String;

    /// `X0,Y0,Z0,X1,Y1,Z1` in mm (the `--stock-box` shortcut).
    fn from_str(s: &str) -> Result<Self, String> {
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("`{s}`: expected X0,Y0,Z0,X1,Y1,Z1 in mm (six numbers)"))?;
        match v.as_slice() {
            &[x0, y0, z0, x1, y1, z1] => Ok(BoxSpec {
                min_mm: [x0, y0, z0],
                max_mm: [x1, y1, z1],
            }),
            _ => Err(format!(
                "`{s}`: expected X0,Y0,Z0,X1,Y1,Z1 in mm (six numbers, got {})",
                v.len()
            )),
        }
    }
}

impl StockFile {
    /// Parse `stock.toml` text that came from `path` (used in errors).
    pub fn parse(path: &Path, text: &str) -> Result<Self, StockError> {
        Ok(acc_config::parse_toml_with(path, text, RANGES)?)
    }

    /// Build the stock; `path` is the file this came from (errors name it, and the height
    /// map's path is relative to it).
    pub fn build(&self, path: &Path) -> Result<ZMap, StockError> {
        let named = |e: StockError| match e {
            StockError::Config(ConfigError::OutOfRange(r)) => {
                StockError::Config(ConfigError::OutOfRange(r.in_file(path)))
            }
            other => other,
        };
        let (lo, hi) = ZMap::CELL_RANGE_MM;
        in_range("cell_mm", self.cell_mm, lo, hi).map_err(|e| named(e.into()))?;
        match (&self.stock_box, &self.height_map) {
            (Some(b), None) => b.zmap(self.cell_mm).map_err(named),
            (None, Some(h)) => h.zmap(path, self.cell_mm).map_err(named),
            (b, _) => Err(ConfigError::Invalid {
                file: path.to_path_buf(),
                key: if b.is_some() { "height_map" } else { "box" }.to_string(),
                message: "give exactly one of [box] and [height_map]".to_string(),
            }
            .into()),
        }
    }
}

impl HeightMapSpec {
    /// Read the file (relative to `stock_toml`) and resample it onto cells of `cell_mm`.
    fn zmap(&self, stock_toml: &Path, cell_mm: f64) -> Result<ZMap, StockError> {
        let key = |k: &str, v: f64, lo: f64, hi: f64| {
            in_range(&format!("height_map.{k}"), v, lo, hi).map_err(StockError::from)
        };
        key("pitch_mm", self.pitch_mm, 0.01, 100.0)?;
        key("bottom_mm", self.bottom_mm, -1e5, 1e5)?;
        key("corner_mm[0]", self.corner_mm[0], -1e5, 1e5)?;
        key("corner_mm[1]", self.corner_mm[1], -1e5, 1e5)?;
        let file = acc_config::resolve_relative(stock_toml, &self.file);
        let grid = read_height_map(&file, self.bottom_mm).map_err(|e| match e {
            StockError::HeightMap {
                line: 0, message, ..
            } if message.starts_with("cannot") => acc_config::referenced(
                stock_toml,
                "height_map.file",
                &self.file,
                ConfigError::Io {
                    file: file.clone(),
                    reason: message,
                },
            )
            .into(),
            other => other,
        })?;
        let width = grid.cols as f64 * self.pitch_mm;
        let depth = grid.rows as f64 * self.pitch_mm;
        let nx = (width / cell_mm).round().max(1.0) as usize;
        let ny = (depth / cell_mm).round().max(1.0) as usize;
        if nx.saturating_mul(ny) > ZMap::MAX_CELLS {
            return Err(RangeError::new(
                "cell_mm",
                cell_mm,
                format!(
                    "a size giving at most {} cells over {width} × {depth} mm",
                    ZMap::MAX_CELLS
                ),
            )
            .into());
        }
        let mut heights = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            let v = (((j as f64 + 0.5) * cell_mm / self.pitch_mm) as usize).min(grid.rows - 1);
            for i in 0..nx {
                let u = (((i as f64 + 0.5) * cell_mm / self.pitch_mm) as usize).min(grid.cols - 1);
                heights.push(grid.heights[v * grid.cols + u]);
            }
        }
        ZMap::from_heights(self.corner_mm, cell_mm, nx, ny, self.bottom_mm, heights)
    }
}

/// Read `stock.toml` at `path` and build the stock it describes.
pub fn load_stock(path: impl AsRef<Path>) -> Result<ZMap, StockError> {
    let path = path.as_ref();
    let file: StockFile = acc_config::load_toml_with(path, RANGES)?;
    file.build(path)
}
