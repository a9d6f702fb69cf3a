//! Garbage in — NaN, negative power, wrong channel count, truncated stream — gives a clear
//! error or a sample flagged invalid, never a force that could raise the feed.

#![allow(clippy::unwrap_used)]

use acc_core::spindle_force::{
    AdaptRule, Constants, EstimatorConfig, Invalid, Method, NoLoadMode, NoLoadModel, PhaseSamples,
    SpindleEstimator, SpindleInput, SpindleSource,
};
use acc_core::{ForceSample, ForceSource, PeriodInput};
use acc_spindle::stream::{SampleFormat, SampleStream, StreamError, StreamForceSource};

fn estimator() -> SpindleEstimator {
    let mut nl = NoLoadModel::new(AdaptRule::default());
    nl.learn(1500.0, 600.0, 24.0).unwrap();
    let cfg = EstimatorConfig {
        method: Method::Power,
        no_load: NoLoadMode::Fixed,
        ..EstimatorConfig::default()
    };
    SpindleEstimator::new(cfg, Constants::default(), nl).unwrap()
}

fn block(n: usize, power_w: f64) -> PhaseSamples {
    PhaseSamples::with_power(n, 1e4, power_w)
}

fn input(ch: &PhaseSamples) -> PeriodInput<'_> {
    PeriodInput {
        period_s: 0.1,
        spindle_rpm: 1500.0,
        phases: Some(ch.block()),
        ..PeriodInput::default()
    }
}

fn assert_invalid(s: ForceSample) {
    assert!(!s.valid, "{s:?}");
    assert_eq!(s.force_n, 0.0);
}

#[test]
fn phase_blocks_with_garbage_are_invalid() {
    let mut src = SpindleSource::new(SpindleInput::Phases, estimator()).unwrap();
    let good = block(1000, 1600.0);
    let s = src.estimate(&input(&good));
    assert!(s.valid && (s.force_n - 159.15).abs() < 0.5, "{s:?}");
    // NaN in one channel.
    let mut nan = good.clone();
    nan.v_uw[417] = f64::NAN;
    assert_invalid(src.estimate(&input(&nan)));
    assert_eq!(src.last(), Some(&Err(Invalid::NonFinite)));
    assert_eq!(
        src.last_block_error().map(|e| e.to_string()),
        Some("non-finite sample in channel v_uw at index 417".to_string())
    );
    // Negative power: current reversed (swapped clamp or regeneration).
    let mut neg = good.clone();
    for x in neg.i_u.iter_mut().chain(neg.i_v.iter_mut()) {
        *x = -*x;
    }
    assert_invalid(src.estimate(&input(&neg)));
    assert_eq!(src.last(), Some(&Err(Invalid::NegativePower)));
    // Wrong channel layout: one channel shorter than the others.
    let mut short = good.clone();
    short.v_vw.truncate(990);
    assert_invalid(src.estimate(&input(&short)));
    assert_eq!(src.last(), Some(&Err(Invalid::BadBlock)));
    // Truncated block: half a period.
    let half = block(500, 1600.0);
    assert_invalid(src.estimate(&input(&half)));
    assert_eq!(src.last(), Some(&Err(Invalid::Truncated)));
    // No block at all.
    assert_invalid(src.estimate(&PeriodInput {
        period_s: 0.1,
        spindle_rpm: 1500.0,
        ..PeriodInput::default()
    }));
}

#[test]
fn board_power_garbage_is_invalid() {
    let mut src = SpindleSource::new(SpindleInput::BoardPower, estimator()).unwrap();
    for p in [f64::NAN, f64::NEG_INFINITY, -1.0, -5000.0] {
        assert_invalid(src.estimate(&PeriodInput {
            period_s: 0.1,
            spindle_rpm: 1500.0,
            power_w: Some(p),
            ..PeriodInput::default()
        }));
    }
    // Far below the no-load power: a broken transducer, not an air cut.
    assert_invalid(src.estimate(&PeriodInput {
        period_s: 0.1,
        spindle_rpm: 1500.0,
        power_w: Some(3.0),
        ..PeriodInput::default()
    }));
    assert_eq!(src.last(), Some(&Err(Invalid::ImplausibleLoad)));
}

fn csv_of(ch: &PhaseSamples, frames: usize) -> String {
    let mut s = String::from("i_u,i_v,v_uw,v_vw\n");
    let it = ch.i_u.iter().zip(&ch.i_v).zip(&ch.v_uw).zip(&ch.v_vw);
    for (((iu, iv), vuw), vvw) in it.take(frames) {
        s.push_str(&format!("{iu},{iv},{vuw},{vvw}\n"));
    }
    s
}

#[test]
fn truncated_and_malformed_streams_are_invalid_and_named() {
    let ch = block(1000, 1600.0);
    // 1.5 periods of CSV: the first period is fine, the second is truncated.
    let text = csv_of(&ch, 1000) + &csv_of(&ch, 500).replacen("i_u,i_v,v_uw,v_vw\n", "", 1);
    let stream = SampleStream::new(text.as_bytes(), SampleFormat::Csv);
    let mut src = StreamForceSource::new(stream, 1e4, estimator()).unwrap();
    let p = PeriodInput {
        period_s: 0.1,
        spindle_rpm: 1500.0,
        ..PeriodInput::default()
    };
    let s = src.estimate(&p);
    assert!(s.valid && (s.force_n - 159.15).abs() < 0.5, "{s:?}");
    assert_invalid(src.estimate(&p));
    assert_eq!(
        src.error().map(|e| e.to_string()),
        Some("line 1501: stream ends inside a period (500 of 1000 samples)".to_string())
    );
    assert_invalid(src.estimate(&p));

    // Wrong channel count on line 3.
    let text = "i_u,i_v,v_uw,v_vw\n1,2,3,4\n1,2,3\n";
    let mut src = StreamForceSource::new(
        SampleStream::new(text.as_bytes(), SampleFormat::Csv),
        1e4,
        estimator(),
    )
    .unwrap();
    assert_invalid(src.estimate(&p));
    assert!(matches!(
        src.error(),
        Some(StreamError::ChannelCount { found: 3, .. })
    ));
    assert!(src.error().unwrap().to_string().starts_with("line 3:"));

    // Raw f32 stream cut inside a frame.
    let mut bytes = Vec::new();
    for k in 0..1000 {
        for c in [&ch.i_u, &ch.i_v, &ch.v_uw, &ch.v_vw] {
            bytes.extend_from_slice(&(c[k] as f32).to_le_bytes());
        }
    }
    bytes.extend_from_slice(&[1, 2, 3]);
    let mut src = StreamForceSource::new(
        SampleStream::new(bytes.as_slice(), SampleFormat::F32Le),
        1e4,
        estimator(),
    )
    .unwrap();
    assert!(src.estimate(&p).valid);
    assert_invalid(src.estimate(&p));
    assert_eq!(
        src.error().map(|e| e.to_string()),
        Some("byte offset 16000: stream ends inside a frame (3 of 16 bytes)".to_string())
    );
}
