//! Three-phase block statistics: Blondel two-wattmeter power, RMS current and voltage,
//! power factor (seed 000, physics.md §2).
//!
//! The DAQ samples the phase currents `i_U`, `i_V` and the line voltages `v_UW`, `v_VW`
//! (W is the common reference). In a three-wire system `i_W = −(i_U + i_V)` and
//! `v_UV = v_UW − v_VW`, so two currents and two line voltages carry all of it.
//!
//! One pass over the block, four accumulator lanes (so the compiler can vectorise it),
//! no allocation. Non-finite samples are detected from the sums (NaN and ±∞ propagate), so
//! the fast path has no per-sample branch; only on error is the block scanned again to
//! name the channel and index.

use super::SpindleError;
use crate::PhaseBlock;

/// Statistics of one block of three-phase samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockStats {
    /// Number of sample instants in the block.
    pub samples: usize,
    /// Mean input power, W: `P = mean(i_U·v_UW + i_V·v_VW)` (Blondel two-wattmeter,
    /// seed 000 eqs. 12–13). Negative while the drive regenerates (spindle braking).
    pub power_w: f64,
    /// Three-phase RMS current, A: `√((I_U² + I_V² + I_W²)/3)` with `i_W = −(i_U + i_V)`
    /// (seed 004, physics.md §3).
    pub current_rms_a: f64,
    /// Mean RMS line voltage of `v_UW`, `v_VW` and `v_UV = v_UW − v_VW`, V.
    pub voltage_rms_v: f64,
    /// Power factor `PF = P / (√3 · I_rms · V_rms)` (seed 000 eq. 1); 0 when the current or
    /// voltage is zero.
    pub power_factor: f64,
}

/// Accumulator lanes: a multiple of the SIMD width for f64 on common targets.
const LANES: usize = 4;

/// Per-lane partial sums.
#[derive(Default, Clone, Copy)]
struct Sums {
    p: [f64; LANES],
    iu2: [f64; LANES],
    iv2: [f64; LANES],
    iuiv: [f64; LANES],
    vuw2: [f64; LANES],
    vvw2: [f64; LANES],
    vuwvvw: [f64; LANES],
}

impl Sums {
    #[inline(always)]
    fn add(&mut self, lane: usize, iu: f64, iv: f64, vuw: f64, vvw: f64) {
        self.p[lane] += iu * vuw + iv * vvw;
        self.iu2[lane] += iu * iu;
        self.iv2[lane] += iv * iv;
        self.iuiv[lane] += iu * iv;
        self.vuw2[lane] += vuw * vuw;
        self.vvw2[lane] += vvw * vvw;
        self.vuwvvw[lane] += vuw * vvw;
    }
}

/// Compute [`BlockStats`] of one block.
///
/// Errors: channels of different lengths, an empty block, a non-finite sample (the error
/// names the channel and the sample index).
///
/// ```
/// use acc_core::spindle_force::power::{block_stats, PhaseSamples};
/// // A balanced 50 Hz system sampled at 10 kHz: 100 V line, 10 A phase, current in phase
/// // with the phase voltage (PF = 1): P = √3 · 100 · 10 = 1732 W.
/// let w = PhaseSamples::balanced(1000, 1e4, 100.0, 10.0, 0.0);
/// let s = block_stats(&w.block()).unwrap();
/// assert!((s.power_w - 1732.05).abs() < 0.1);
/// assert!((s.current_rms_a - 10.0).abs() < 1e-6);
/// assert!((s.voltage_rms_v - 100.0).abs() < 1e-6);
/// assert!((s.power_factor - 1.0).abs() < 1e-6);
/// ```
pub fn block_stats(block: &PhaseBlock<'_>) -> Result<BlockStats, SpindleError> {
    let n = block.i_u.len();
    if block.i_v.len() != n || block.v_uw.len() != n || block.v_vw.len() != n {
        return Err(SpindleError::LengthMismatch {
            i_u: n,
            i_v: block.i_v.len(),
            v_uw: block.v_uw.len(),
            v_vw: block.v_vw.len(),
        });
    }
    if n == 0 {
        return Err(SpindleError::EmptyBlock);
    }
    let mut s = Sums::default();
    let chunks = n / LANES * LANES;
    let (iu_c, iu_r) = block.i_u.split_at(chunks);
    let (iv_c, iv_r) = block.i_v.split_at(chunks);
    let (vuw_c, vuw_r) = block.v_uw.split_at(chunks);
    let (vvw_c, vvw_r) = block.v_vw.split_at(chunks);
    for (((iu, iv), vuw), vvw) in iu_c
        .chunks_exact(LANES)
        .zip(iv_c.chunks_exact(LANES))
        .zip(vuw_c.chunks_exact(LANES))
        .zip(vvw_c.chunks_exact(LANES))
    {
        for l in 0..LANES {
            s.add(l, iu[l], iv[l], vuw[l], vvw[l]);
        }
    }
    for (l, (((iu, iv), vuw), vvw)) in iu_r.iter().zip(iv_r).zip(vuw_r).zip(vvw_r).enumerate() {
        s.add(l, *iu, *iv, *vuw, *vvw);
    }
    let sum = |a: &[f64; LANES]| a.iter().sum::<f64>();
    let (p, iu2, iv2, iuiv) = (sum(&s.p), sum(&s.iu2), sum(&s.iv2), sum(&s.iuiv));
    let (vuw2, vvw2, vuwvvw) = (sum(&s.vuw2), sum(&s.vvw2), sum(&s.vuwvvw));
    let all = [p, iu2, iv2, iuiv, vuw2, vvw2, vuwvvw];
    if all.iter().any(|x| !x.is_finite()) {
        return Err(first_non_finite(block));
    }
    let nf = n as f64;
    // i_W² = (i_U + i_V)²; v_UV² = (v_UW − v_VW)².
    let iw2 = iu2 + 2.0 * iuiv + iv2;
    let vuv2 = vuw2 - 2.0 * vuwvvw + vvw2;
    let current_rms_a = ((iu2 + iv2 + iw2) / (3.0 * nf)).max(0.0).sqrt();
    let voltage_rms_v = ((vuw2 + vvw2 + vuv2) / (3.0 * nf)).max(0.0).sqrt();
    let power_w = p / nf;
    let apparent = 3f64.sqrt() * current_rms_a * voltage_rms_v;
    let power_factor = if apparent > 0.0 {
        power_w / apparent
    } else {
        0.0
    };
    Ok(BlockStats {
        samples: n,
        power_w,
        current_rms_a,
        voltage_rms_v,
        power_factor,
    })
}

/// Owned channels of a three-phase block (`i_U`, `i_V`, `v_UW`, `v_VW`), e.g. a synthetic
/// test signal or a buffered recording.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PhaseSamples {
    /// Sampling rate, Hz.
    pub sample_rate_hz: f64,
    /// Phase current U, A.
    pub i_u: Vec<f64>,
    /// Phase current V, A.
    pub i_v: Vec<f64>,
    /// Line voltage U–W, V.
    pub v_uw: Vec<f64>,
    /// Line voltage V–W, V.
    pub v_vw: Vec<f64>,
}

impl PhaseSamples {
    /// A balanced sinusoidal three-phase system: `n` samples at `sample_rate_hz`, 50 Hz,
    /// RMS line voltage `v_line`, RMS phase current `i_a` lagging the phase voltage by
    /// `phi` rad. Its power is `√3·v_line·i_a·cos φ` (seed 000 eq. 1).
    pub fn balanced(n: usize, sample_rate_hz: f64, v_line: f64, i_a: f64, phi: f64) -> Self {
        let third = 2.0 * std::f64::consts::PI / 3.0;
        let vph = v_line / 3f64.sqrt() * 2f64.sqrt();
        let ipk = i_a * 2f64.sqrt();
        let mut s = Self {
            sample_rate_hz,
            ..Self::default()
        };
        for k in 0..n {
            let th = 2.0 * std::f64::consts::PI * 50.0 * k as f64 / sample_rate_hz;
            let (vu, vv, vw) = (
                vph * th.cos(),
                vph * (th - third).cos(),
                vph * (th + third).cos(),
            );
            s.i_u.push(ipk * (th - phi).cos());
            s.i_v.push(ipk * (th - third - phi).cos());
            s.v_uw.push(vu - vw);
            s.v_vw.push(vv - vw);
        }
        s
    }

    /// A balanced system at unity power factor drawing `power_w` at 200 V.
    pub fn with_power(n: usize, sample_rate_hz: f64, power_w: f64) -> Self {
        Self::balanced(
            n,
            sample_rate_hz,
            200.0,
            power_w / (3f64.sqrt() * 200.0),
            0.0,
        )
    }

    /// Borrow as a [`PhaseBlock`], every channel as it is (channels of unequal length stay
    /// unequal, so [`block_stats`] reports them instead of silently truncating).
    pub fn block(&self) -> PhaseBlock<'_> {
        PhaseBlock {
            sample_rate_hz: self.sample_rate_hz,
            i_u: &self.i_u,
            i_v: &self.i_v,
            v_uw: &self.v_uw,
            v_vw: &self.v_vw,
        }
    }

    /// Samples per channel (the shortest channel's length).
    pub fn len(&self) -> usize {
        [&self.i_u, &self.i_v, &self.v_uw, &self.v_vw]
            .iter()
            .map(|c| c.len())
            .min()
            .unwrap_or(0)
    }

    /// `true` when no channel holds a sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Borrow the last `n` samples of every channel (a channel shorter than `n` whole) as a
    /// [`PhaseBlock`], e.g. a measurement window at the end of a control period.
    pub fn tail_block(&self, n: usize) -> PhaseBlock<'_> {
        let tail = |c: &'_ Vec<f64>| -> usize { c.len() - n.min(c.len()) };
        PhaseBlock {
            sample_rate_hz: self.sample_rate_hz,
            i_u: &self.i_u[tail(&self.i_u)..],
            i_v: &self.i_v[tail(&self.i_v)..],
            v_uw: &self.v_uw[tail(&self.v_uw)..],
            v_vw: &self.v_vw[tail(&self.v_vw)..],
        }
    }

    /// Empty every channel, keeping the allocations (per-block reuse).
    pub fn clear(&mut self) {
        for c in [&mut self.i_u, &mut self.i_v, &mut self.v_uw, &mut self.v_vw] {
            c.clear();
        }
    }
}

/// The first non-finite sample of a block (error path only), or a product overflow.
fn first_non_finite(block: &PhaseBlock<'_>) -> SpindleError {
    let channels: [(&'static str, &[f64]); 4] = [
        ("i_u", block.i_u),
        ("i_v", block.i_v),
        ("v_uw", block.v_uw),
        ("v_vw", block.v_vw),
    ];
    let mut first: Option<(usize, &'static str)> = None;
    for (name, data) in channels {
        if let Some(k) = data.iter().position(|x| !x.is_finite()) {
            if first.is_none_or(|(k0, _)| k < k0) {
                first = Some((k, name));
            }
        }
    }
    match first {
        Some((index, channel)) => SpindleError::NonFinite { channel, index },
        None => SpindleError::Overflow,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tail_block_is_the_end_of_every_channel() {
        let s = PhaseSamples {
            sample_rate_hz: 1000.0,
            i_u: vec![1.0, 2.0, 3.0, 4.0],
            i_v: vec![5.0, 6.0, 7.0, 8.0],
            v_uw: vec![9.0, 10.0, 11.0, 12.0],
            v_vw: vec![13.0, 14.0, 15.0, 16.0],
        };
        assert_eq!(s.len(), 4);
        let t = s.tail_block(2);
        assert_eq!((t.i_u, t.i_v), (&[3.0, 4.0][..], &[7.0, 8.0][..]));
        assert_eq!((t.v_uw, t.v_vw), (&[11.0, 12.0][..], &[15.0, 16.0][..]));
        assert_eq!(s.tail_block(10).i_u.len(), 4);
        let mut c = s.clone();
        c.clear();
        assert!(c.is_empty());
    }

    fn wave(n: usize, v_line: f64, i_a: f64, phi: f64) -> PhaseSamples {
        PhaseSamples::balanced(n, 1e4, v_line, i_a, phi)
    }

    #[test]
    fn power_factor_follows_phase_angle() {
        // 0.1 s holds whole 50 Hz cycles: the block mean is exact.
        for phi in [0.0, 0.3, 0.8, 1.2] {
            let w = wave(1000, 200.0, 30.0, phi);
            let s = block_stats(&w.block()).unwrap();
            let p = 3f64.sqrt() * 200.0 * 30.0 * f64::cos(phi);
            assert!((s.power_w - p).abs() < 1e-6 * p.abs().max(1.0), "{phi}");
            assert!((s.power_factor - phi.cos()).abs() < 1e-9);
        }
    }

    #[test]
    fn remainder_lanes_are_counted() {
        // 1003 is not a multiple of LANES: compare with a plain loop.
        let w = wave(1003, 200.0, 30.0, 0.5);
        let s = block_stats(&w.block()).unwrap();
        let p: f64 = (0..1003)
            .map(|k| w.i_u[k] * w.v_uw[k] + w.i_v[k] * w.v_vw[k])
            .sum::<f64>()
            / 1003.0;
        assert!((s.power_w - p).abs() < 1e-9 * p);
        assert_eq!(s.samples, 1003);
    }

    #[test]
    fn garbage_is_named() {
        let mut w = wave(100, 200.0, 30.0, 0.5);
        w.v_vw[57] = f64::NAN;
        w.i_u[80] = f64::INFINITY;
        assert_eq!(
            block_stats(&w.block()),
            Err(SpindleError::NonFinite {
                channel: "v_vw",
                index: 57
            })
        );
        w.i_v.pop();
        assert!(matches!(
            block_stats(&w.block()),
            Err(SpindleError::LengthMismatch { i_v: 99, .. })
        ));
        let e = PhaseSamples::default();
        assert_eq!(block_stats(&e.block()), Err(SpindleError::EmptyBlock));
    }
}
