//! Closed-loop stability analysis: poles, Jury test, stable Kc ranges.
