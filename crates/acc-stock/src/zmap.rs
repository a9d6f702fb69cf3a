//! The 2.5D height field (Z-map): a grid of square cells over the XY plane, each holding
//! the height of the material column standing on the stock bottom.
//!
//! Cell `(i, j)` covers `[x0 + i·c, x0 + (i+1)·c) × [y0 + j·c, y0 + (j+1)·c)` and holds the
//! top `h` of a column of material from the stock bottom `z0` up to `h` (`h = z0`: no
//! material). Heights are `f32` (0.1 µm resolution at 1 m heights): half the memory and
//! cache traffic of `f64` in the inner loop. Outside the grid there is no material.

use crate::error::{in_range, StockError};

/// Height-field stock. See the module docs for the cell layout.
#[derive(Debug, Clone, PartialEq)]
pub struct ZMap {
    x0_mm: f64,
    y0_mm: f64,
    cell_mm: f64,
    nx: usize,
    ny: usize,
    bottom_mm: f64,
    heights: Vec<f32>,
}

/// Cells of the map removed in one cut, with the removed volume.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Removal {
    /// Removed volume, mm³.
    pub volume_mm3: f64,
    /// Largest thickness removed from one cell, mm.
    pub max_depth_mm: f64,
}

impl ZMap {
    /// Default cell size, mm.
    pub const DEFAULT_CELL_MM: f64 = 0.25;
    /// Allowed cell size, mm.
    pub const CELL_RANGE_MM: (f64, f64) = (0.01, 10.0);
    /// Most cells a map may have (about 400 MB of heights).
    pub const MAX_CELLS: usize = 100_000_000;

    /// A map of `nx × ny` cells of side `cell_mm` (mm) with its corner at `(x0_mm, y0_mm)`,
    /// the stock bottom at `bottom_mm` and every column up to `top_mm` (mm).
    pub fn filled(
        corner_mm: [f64; 2],
        cell_mm: f64,
        nx: usize,
        ny: usize,
        bottom_mm: f64,
        top_mm: f64,
    ) -> Result<Self, StockError> {
        let n = Self::check_shape(cell_mm, nx, ny)?;
        Self::from_heights(
            corner_mm,
            cell_mm,
            nx,
            ny,
            bottom_mm,
            vec![top_mm as f32; n],
        )
    }

    /// A box stock `[x0, x1] × [y0, y1] × [z0, z1]` (mm) on cells of `cell_mm` (mm). The
    /// extent is snapped to whole cells: `nx = round((x1 − x0)/c)`, likewise `ny`, so the
    /// grid ends within c/2 of `x1`, `y1`. Errors name `box.max_mm` when a side is empty and
    /// `cell_mm` when it is out of [`ZMap::CELL_RANGE_MM`] or makes too many cells.
    pub fn from_box(min_mm: [f64; 3], max_mm: [f64; 3], cell_mm: f64) -> Result<Self, StockError> {
        let (lo, hi) = Self::CELL_RANGE_MM;
        in_range("cell_mm", cell_mm, lo, hi)?;
        for k in 0..3 {
            in_range(&format!("box.min_mm[{k}]"), min_mm[k], -1e5, 1e5)?;
            in_range(&format!("box.max_mm[{k}]"), max_mm[k], -1e5, 1e5)?;
            if max_mm[k] <= min_mm[k] {
                return Err(acc_config::RangeError::new(
                    format!("box.max_mm[{k}]"),
                    max_mm[k],
                    format!("> box.min_mm[{k}] = {}", min_mm[k]),
                )
                .into());
            }
        }
        let nx = ((max_mm[0] - min_mm[0]) / cell_mm).round().max(1.0) as usize;
        let ny = ((max_mm[1] - min_mm[1]) / cell_mm).round().max(1.0) as usize;
        Self::filled(
            [min_mm[0], min_mm[1]],
            cell_mm,
            nx,
            ny,
            min_mm[2],
            max_mm[2],
        )
    }

    /// A map from its heights, row by row in +Y (`heights[j·nx + i]`, mm); every height
    /// must lie in `bottom_mm ..= bottom_mm + 1e4`.
    pub fn from_heights(
        corner_mm: [f64; 2],
        cell_mm: f64,
        nx: usize,
        ny: usize,
        bottom_mm: f64,
        heights: Vec<f32>,
    ) -> Result<Self, StockError> {
        let n = Self::check_shape(cell_mm, nx, ny)?;
        in_range("corner_mm[0]", corner_mm[0], -1e5, 1e5)?;
        in_range("corner_mm[1]", corner_mm[1], -1e5, 1e5)?;
        in_range("bottom_mm", bottom_mm, -1e5, 1e5)?;
        if heights.len() != n {
            return Err(acc_config::RangeError::new(
                "heights.len()",
                heights.len(),
                format!("{n} (= nx·ny)"),
            )
            .into());
        }
        for (k, &h) in heights.iter().enumerate() {
            in_range(
                &format!("heights[{k}]"),
                f64::from(h),
                bottom_mm - 1e-3,
                bottom_mm + 1e4,
            )?;
        }
        Ok(ZMap {
            x0_mm: corner_mm[0],
            y0_mm: corner_mm[1],
            cell_mm,
            nx,
            ny,
            bottom_mm,
            heights,
        })
    }

    fn check_shape(cell_mm: f64, nx: usize, ny: usize) -> Result<usize, StockError> {
        let (lo, hi) = Self::CELL_RANGE_MM;
        in_range("cell_mm", cell_mm, lo, hi)?;
        let n = nx.saturating_mul(ny);
        if nx == 0 || ny == 0 || n > Self::MAX_CELLS {
            return Err(acc_config::RangeError::new(
                "cell_mm",
                cell_mm,
                format!(
                    "a size giving 1 ..= {} cells (here {nx} × {ny})",
                    Self::MAX_CELLS
                ),
            )
            .into());
        }
        Ok(n)
    }

    /// Cell side c, mm.
    pub fn cell_mm(&self) -> f64 {
        self.cell_mm
    }

    /// Number of cells along X and along Y.
    pub fn size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Corner `(x0, y0)` of cell (0, 0), mm.
    pub fn corner_mm(&self) -> [f64; 2] {
        [self.x0_mm, self.y0_mm]
    }

    /// Far corner `(x0 + nx·c, y0 + ny·c)` of the grid, mm.
    pub fn far_corner_mm(&self) -> [f64; 2] {
        [
            self.x0_mm + self.nx as f64 * self.cell_mm,
            self.y0_mm + self.ny as f64 * self.cell_mm,
        ]
    }

    /// Stock bottom z0, mm (a column of height z0 holds no material).
    pub fn bottom_mm(&self) -> f64 {
        self.bottom_mm
    }

    /// Heights, row by row in +Y (`[j·nx + i]`), mm.
    pub fn heights(&self) -> &[f32] {
        &self.heights
    }

    /// Height of cell `(i, j)`, mm (`None` outside the grid).
    pub fn cell_height(&self, i: usize, j: usize) -> Option<f64> {
        (i < self.nx && j < self.ny).then(|| f64::from(self.heights[j * self.nx + i]))
    }

    /// Height of the column containing the point `(x, y)` (mm), mm; `None` outside the grid.
    #[inline]
    pub fn height_at(&self, x_mm: f64, y_mm: f64) -> Option<f64> {
        let u = (x_mm - self.x0_mm) / self.cell_mm;
        let v = (y_mm - self.y0_mm) / self.cell_mm;
        if u < 0.0 || v < 0.0 {
            return None;
        }
        let (i, j) = (u as usize, v as usize);
        (i < self.nx && j < self.ny).then(|| f64::from(self.heights[j * self.nx + i]))
    }

    /// The centre `(x, y)` (mm) and height (mm) of the cell containing the point `(x, y)`
    /// (mm); `None` outside the grid.
    #[inline]
    pub fn cell_at(&self, x_mm: f64, y_mm: f64) -> Option<(f64, f64, f64)> {
        let u = (x_mm - self.x0_mm) / self.cell_mm;
        let v = (y_mm - self.y0_mm) / self.cell_mm;
        if u < 0.0 || v < 0.0 {
            return None;
        }
        let (i, j) = (u as usize, v as usize);
        (i < self.nx && j < self.ny).then(|| {
            (
                self.x0_mm + (i as f64 + 0.5) * self.cell_mm,
                self.y0_mm + (j as f64 + 0.5) * self.cell_mm,
                f64::from(self.heights[j * self.nx + i]),
            )
        })
    }

    /// Highest column top, mm (the bottom when the map is empty of material).
    pub fn max_height_mm(&self) -> f64 {
        self.heights
            .iter()
            .fold(self.bottom_mm, |m, &h| m.max(f64::from(h)))
    }

    /// Volume of material, mm³: `Σ (h − z0)·c²`.
    pub fn volume_mm3(&self) -> f64 {
        let z0 = self.bottom_mm;
        let s: f64 = self
            .heights
            .iter()
            .map(|&h| (f64::from(h) - z0).max(0.0))
            .sum();
        s * self.cell_mm * self.cell_mm
    }

    /// Lower every column whose cell centre lies in `[x0, x1] × [y0, y1]` (mm) to at most
    /// `z_mm` (never below the bottom); returns the removed volume. For building stocks
    /// (a pre-cut pocket, a step) and tests.
    pub fn lower_rect(&mut self, min_mm: [f64; 2], max_mm: [f64; 2], z_mm: f64) -> f64 {
        let c = self.cell_mm;
        let z = z_mm.max(self.bottom_mm) as f32;
        let mut removed = 0.0;
        for j in 0..self.ny {
            let yc = self.y0_mm + (j as f64 + 0.5) * c;
            if yc < min_mm[1] || yc > max_mm[1] {
                continue;
            }
            for i in 0..self.nx {
                let xc = self.x0_mm + (i as f64 + 0.5) * c;
                let h = &mut self.heights[j * self.nx + i];
                if xc >= min_mm[0] && xc <= max_mm[0] && *h > z {
                    removed += f64::from(*h - z);
                    *h = z;
                }
            }
        }
        removed * c * c
    }

    /// The cells of a disc of radius `radius_mm` centred at `(x, y)` (mm) whose centres lie
    /// inside it, row by row ([`Disc::rows`]).
    fn disc(&self, x_mm: f64, y_mm: f64, radius_mm: f64) -> Disc {
        let c = self.cell_mm;
        Disc {
            // Continuous cell index of the centre, such that cell k's centre is at index k.
            fx: (x_mm - self.x0_mm) / c - 0.5,
            fy: (y_mm - self.y0_mm) / c - 0.5,
            rc: radius_mm / c,
            nx: self.nx,
            ny: self.ny,
        }
    }

    /// Cut with a flat end face of radius `radius_mm` (mm) centred at `(x, y)` (mm) with its
    /// tip at `tip_mm`: every column whose cell centre lies within the radius is lowered to
    /// the tip (never below the bottom). Visits only the rows of the disc's bounding box and,
    /// per row, the contiguous span of cells inside the disc.
    pub fn cut_flat_disc(&mut self, x_mm: f64, y_mm: f64, radius_mm: f64, tip_mm: f64) -> Removal {
        let c = self.cell_mm;
        let z = tip_mm.max(self.bottom_mm) as f32;
        let disc = self.disc(x_mm, y_mm, radius_mm);
        let mut volume = 0.0f64;
        let mut max_depth = 0.0f32;
        for (j, i_lo, i_hi, _) in disc.rows() {
            let row = &mut self.heights[j * self.nx..(j + 1) * self.nx];
            let mut row_volume = 0.0f32;
            for h in &mut row[i_lo..=i_hi] {
                let d = (*h - z).max(0.0);
                row_volume += d;
                max_depth = max_depth.max(d);
                *h = h.min(z);
            }
            volume += f64::from(row_volume);
        }
        Removal {
            volume_mm3: volume * c * c,
            max_depth_mm: f64::from(max_depth),
        }
    }

    /// Cut with a ball nose of radius `radius_mm` (mm) centred at `(x, y)` (mm) with its
    /// lowest point at `tip_mm`: every column whose cell centre lies within the radius, at
    /// distance r from the axis, is lowered to `tip + R − √(R² − r²)` (never below the
    /// bottom). Same visiting order as [`ZMap::cut_flat_disc`], one `sqrt` per cell.
    pub fn cut_ball(&mut self, x_mm: f64, y_mm: f64, radius_mm: f64, tip_mm: f64) -> Removal {
        let c = self.cell_mm;
        let bottom = self.bottom_mm;
        let disc = self.disc(x_mm, y_mm, radius_mm);
        let r2 = radius_mm * radius_mm;
        let mut volume = 0.0f64;
        let mut max_depth = 0.0f64;
        for (j, i_lo, i_hi, dy) in disc.rows() {
            let dy_mm = dy * c;
            for i in i_lo..=i_hi {
                let dx_mm = (i as f64 - disc.fx) * c;
                let d2 = dx_mm * dx_mm + dy_mm * dy_mm;
                // Compared in f32, as stored: a second pass at the same place cuts nothing.
                let z = (tip_mm + radius_mm - (r2 - d2).max(0.0).sqrt()).max(bottom) as f32;
                let h = &mut self.heights[j * self.nx + i];
                if *h > z {
                    let d = f64::from(*h - z);
                    volume += d;
                    max_depth = max_depth.max(d);
                    *h = z;
                }
            }
        }
        Removal {
            volume_mm3: volume * c * c,
            max_depth_mm: max_depth,
        }
    }
}

/// A disc on the grid, in cell units (see [`ZMap::disc`]).
#[derive(Debug, Clone, Copy)]
struct Disc {
    fx: f64,
    fy: f64,
    rc: f64,
    nx: usize,
    ny: usize,
}

impl Disc {
    /// Per grid row inside the disc: the row `j`, the first and last column `i_lo ..= i_hi`
    /// whose cell centres lie inside, and the row's offset from the centre `dy`, cells.
    fn rows(self) -> impl Iterator<Item = (usize, usize, usize, f64)> {
        let j_lo = (self.fy - self.rc).ceil().max(0.0);
        let j_hi = (self.fy + self.rc).floor().min(self.ny as f64 - 1.0);
        let rows = if j_hi < j_lo {
            0..0
        } else {
            j_lo as usize..j_hi as usize + 1
        };
        rows.filter_map(move |j| {
            let dy = j as f64 - self.fy;
            let w2 = self.rc * self.rc - dy * dy;
            if w2 < 0.0 {
                return None;
            }
            let w = w2.sqrt();
            let i_lo = (self.fx - w).ceil().max(0.0);
            let i_hi = (self.fx + w).floor().min(self.nx as f64 - 1.0);
            (i_hi >= i_lo).then_some((j, i_lo as usize, i_hi as usize, dy))
        })
    }
}
