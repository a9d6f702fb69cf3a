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

use acc_core::PhaseBlock;

use crate::SpindleError;

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
/// use acc_core::PhaseBlock;
/// use acc_spindle::power::block_stats;
/// // A balanced 50 Hz system sampled at 10 kHz: 100 V line, 10 A phase, current in phase
/// // with the phase voltage (PF = 1): P = √3 · 100 · 10 = 1732 W.
/// let n = 1000;
/// let (mut iu, mut iv, mut vuw, mut vvw) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
/// let third = 2.0 * std::f64::consts::PI / 3.0;
/// for k in 0..n {
///     let th = 2.0 * std::f64::consts::PI * 50.0 * k as f64 / 1e4;
///     let vph = 100.0 / 3f64.sqrt() * 2f64.sqrt();
///     let (vu, vv, vw) = (vph * th.cos(), vph * (th - third).cos(), vph * (th + third).cos());
///     iu[k] = 10.0 * 2f64.sqrt() * th.cos();
///     iv[k] = 10.0 * 2f64.sqrt() * (th - third).cos();
///     vuw[k] = vu - vw;
///     vvw[k] = vv - vw;
/// }
/// let s = block_stats(&PhaseBlock { sample_rate_hz: 1e4, i_u: &iu, i_v: &iv, v_uw: &vuw, v_vw: &vvw }).unwrap();
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
    use std::f64::consts::PI;

    struct Wave {
        iu: Vec<f64>,
        iv: Vec<f64>,
        vuw: Vec<f64>,
        vvw: Vec<f64>,
    }

    /// Balanced sinusoidal system, current lagging the phase voltage by `phi`.
    fn wave(n: usize, v_line: f64, i_a: f64, phi: f64) -> Wave {
        let third = 2.0 * PI / 3.0;
        let vph = v_line / 3f64.sqrt() * 2f64.sqrt();
        let mut w = Wave {
            iu: vec![],
            iv: vec![],
            vuw: vec![],
            vvw: vec![],
        };
        for k in 0..n {
            let th = 2.0 * PI * 50.0 * k as f64 / 1e4;
            let (vu, vv, vw) = (
                vph * th.cos(),
                vph * (th - third).cos(),
                vph * (th + third).cos(),
            );
            w.iu.push(i_a * 2f64.sqrt() * (th - phi).cos());
            w.iv.push(i_a * 2f64.sqrt() * (th - third - phi).cos());
            w.vuw.push(vu - vw);
            w.vvw.push(vv - vw);
        }
        w
    }

    fn block(w: &Wave) -> PhaseBlock<'_> {
        PhaseBlock {
            sample_rate_hz: 1e4,
            i_u: &w.iu,
            i_v: &w.iv,
            v_uw: &w.vuw,
            v_vw: &w.vvw,
        }
    }

    #[test]
    fn power_factor_follows_phase_angle() {
        // 0.1 s holds whole 50 Hz cycles: the block mean is exact.
        for phi in [0.0, 0.3, 0.8, 1.2] {
            let w = wave(1000, 200.0, 30.0, phi);
            let s = block_stats(&block(&w)).unwrap();
            let p = 3f64.sqrt() * 200.0 * 30.0 * f64::cos(phi);
            assert!((s.power_w - p).abs() < 1e-6 * p.abs().max(1.0), "{phi}");
            assert!((s.power_factor - phi.cos()).abs() < 1e-9);
        }
    }

    #[test]
    fn remainder_lanes_are_counted() {
        // 1003 is not a multiple of LANES: compare with a plain loop.
        let w = wave(1003, 200.0, 30.0, 0.5);
        let s = block_stats(&block(&w)).unwrap();
        let p: f64 = (0..1003)
            .map(|k| w.iu[k] * w.vuw[k] + w.iv[k] * w.vvw[k])
            .sum::<f64>()
            / 1003.0;
        assert!((s.power_w - p).abs() < 1e-9 * p);
        assert_eq!(s.samples, 1003);
    }

    #[test]
    fn garbage_is_named() {
        let mut w = wave(100, 200.0, 30.0, 0.5);
        w.vvw[57] = f64::NAN;
        w.iu[80] = f64::INFINITY;
        assert_eq!(
            block_stats(&block(&w)),
            Err(SpindleError::NonFinite {
                channel: "v_vw",
                index: 57
            })
        );
        w.iv.pop();
        assert!(matches!(
            block_stats(&block(&w)),
            Err(SpindleError::LengthMismatch { i_v: 99, .. })
        ));
        let e: [f64; 0] = [];
        let b = PhaseBlock {
            sample_rate_hz: 1e4,
            i_u: &e,
            i_v: &e,
            v_uw: &e,
            v_vw: &e,
        };
        assert_eq!(block_stats(&b), Err(SpindleError::EmptyBlock));
    }
}
