//! Analysis of measured series (physics core: imports nothing above it). Today the
//! least-squares fits of the measurements; the glottal-flow measures (f0, OQ, SQ, MFDR, NAQ,
//! H1–H2) come with the glottis issue.

pub mod fit;
