//! `acc-plot`: SVG and PNG plots with an embedded font.
