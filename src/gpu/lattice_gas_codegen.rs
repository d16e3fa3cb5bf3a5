//! Generates the per-velocity parts of `shaders/lattice_gas.wgsl` (DESIGN §7: unrolled WGSL for
//! the lattice kernels): the class key from popcounts, the collision's bit gather / scatter over
//! the 24 words, the interference masks and the propagation moves — all from the same tables as
//! the CPU twin ([`crate::lattice_gas::bits`], [`crate::lattice_gas::collision::AXIS_MASKS`]).

use crate::lattice_gas::bits::{axes, complementary_sides, interference_sides, propagation_moves};
use crate::lattice_gas::collision::{AXIS_MASKS, COMPLEMENTARY_STREAM, INLET_STREAM, INTERFERENCE_STREAM};
use crate::lattice_gas::velocities::{Q, opposite};
use std::fmt::Write;

const TEMPLATE: &str = include_str!("../../shaders/lattice_gas.wgsl");

fn replicate32(m: u16) -> u32 {
    m as u32 * 0x0001_0001
}

fn class_key() -> String {
    let mut s = String::from("fn class_key(s: u32) -> u32 {\n    var key = countOneBits(s);\n");
    for a in 0..4 {
        let _ = writeln!(
            s,
            "    key = key * 13u + u32(i32(countOneBits(s & {:#010x}u)) - i32(countOneBits(s & {:#010x}u)) + 6);",
            AXIS_MASKS[0][a], AXIS_MASKS[1][a]
        );
    }
    s + "    return key;\n}\n"
}

fn collide() -> String {
    let mut s = String::new();
    for k in 0..Q {
        let _ = writeln!(s, "    let i{k} = src[{k}u * W + w];\n    var o{k} = 0u;");
    }
    s += "    for (var lane = 0u; lane < 2u; lane++) {\n        let cell = 2u * w + lane;\n";
    s += "        if (((sol >> lane) & 1u) == 1u) {\n            let m = 0xFFFFu << (16u * lane);\n";
    for k in 0..Q {
        let _ = writeln!(s, "            o{} |= i{k} & m;", opposite(k));
    }
    s += "            continue;\n        }\n        for (var v = 0u; v < 16u; v++) {\n            let bit = 16u * lane + v;\n";
    s += "            let s = ((i0 >> bit) & 1u)";
    for k in 1..Q {
        let _ = write!(s, "\n                | (((i{k} >> bit) & 1u) << {k}u)");
    }
    s += ";\n            let t = collide_state(s, mix32((cell * 16u + v) ^ h));\n";
    for k in 0..Q {
        let _ = writeln!(s, "            o{k} |= ((t >> {k}u) & 1u) << bit;");
    }
    s += "        }\n    }\n";
    s
}

/// Writes the collided words o0..o23 back.
fn store() -> String {
    (0..Q).map(|k| format!("    src[{k}u * W + w] = o{k};\n")).collect()
}

/// The interference of every velocity on one lane (`cell`, `shift` in scope), with the random
/// hashes `hash` (own plane) and `complementary` (the two complementary-plane diagonals, when
/// `P.diagonals` is 1); `word(k)` is the expression of velocity k's word, read and assigned in
/// place. Per velocity the order is the CPU's: own plane, then the diagonals of
/// [`complementary_sides`] in order.
fn interference_blocks(hash: &str, complementary: &str, word: impl Fn(usize) -> String) -> String {
    let exchange = |draw: String, a: usize, b: usize, ma: u16, mb: u16, x: &str| {
        format!(
            "            if ({draw} < P.interference) {{\n                let x = {x};\n                let n = interfere_lane((x >> shift) & 0xFFFFu, {a}u, {b}u, {ma:#06x}u, {mb:#06x}u);\n                {x} = (x & ~(0xFFFFu << shift)) | (n << shift);\n            }}\n"
        )
    };
    let mut s = String::new();
    for k in 0..Q {
        let ((a, _), (b, _)) = axes(k);
        let (ma, mb) = interference_sides(k);
        let x = word(k);
        s += &exchange(format!("mix32((cell * 24u + {k}u) ^ {hash})"), a, b, ma, mb, &x);
        s += "            if (P.diagonals == 1u) {\n";
        for (j, (ma, mb, p, q)) in complementary_sides(k).into_iter().enumerate() {
            s += &exchange(format!("mix32(((cell * 24u + {k}u) * 2u + {j}u) ^ {complementary})"), p, q, ma, mb, &x);
        }
        s += "            }\n";
    }
    s
}

fn propagate() -> String {
    let mut s = String::new();
    // the rows of the 9 (Y, Z) offsets
    for oy in -1i64..=1 {
        for oz in -1i64..=1 {
            let ey = match oy {
                -1 => "(y + P.ny - 1u) % P.ny",
                0 => "y",
                _ => "(y + 1u) % P.ny",
            };
            let ez = match oz {
                -1 => "(z + P.nz - 1u) % P.nz",
                0 => "z",
                _ => "(z + 1u) % P.nz",
            };
            let _ = writeln!(s, "    let row_{}_{} = (({ez}) * P.ny + {ey}) * rw;", oy + 1, oz + 1);
        }
    }
    for k in 0..Q {
        let _ = writeln!(s, "    {{\n        var acc = 0u;");
        for (mask, off, rotation) in propagation_moves(k) {
            let row = format!("{k}u * W + row_{}_{}", off[1] + 1, off[2] + 1);
            let src = match off[0] {
                0 => format!("src[{row} + xw]"),
                -1 => format!("(src[{row} + xw] << 16u) | (src[{row} + xm] >> 16u)"),
                _ => format!("(src[{row} + xw] >> 16u) | (src[{row} + xp] << 16u)"),
            };
            // the quadrant flipped on both axes of c_k: one shift by ±2^a ± 2^b (|·| ≤ 12, the
            // vertices stay in their 16-bit lane; `bits::quadrant_flip_rotation`)
            let shift = if rotation < 32 { format!("<< {rotation}u") } else { format!(">> {}u", 64 - rotation) };
            let _ = writeln!(s, "        acc |= (({src}) & {:#010x}u) {shift};", replicate32(mask));
        }
        let _ = writeln!(s, "        dst[{k}u * W + w] = acc;\n    }}");
    }
    s
}

/// The complete lattice-gas shader.
pub fn shader() -> String {
    // the template's stream salts must be the CPU's
    assert!(TEMPLATE.contains(&format!("INTERFERENCE_STREAM: u32 = {INTERFERENCE_STREAM:#010x}u")));
    assert!(TEMPLATE.contains(&format!("INLET_STREAM: u32 = {INLET_STREAM:#010x}u")));
    assert!(TEMPLATE.contains(&format!("COMPLEMENTARY_STREAM: u32 = {COMPLEMENTARY_STREAM:#010x}u")));
    let wgsl = TEMPLATE
        .replace("//@CLASS_KEY", &class_key())
        .replace("//@COLLIDE", &collide())
        .replace("//@STORE", &store())
        // the fused kernel works on the collided words in registers, `interfere` on memory
        .replace("//@REGISTER_INTERFERENCE", &interference_blocks("hi", "hc", |k| format!("o{k}")))
        .replace("//@INTERFERE", &interference_blocks("h", "hc", |k| format!("src[{k}u * W + w]")))
        .replace("//@PROPAGATE", &propagate());
    assert!(!wgsl.contains("//@"), "a marker of shaders/lattice_gas.wgsl was left unfilled");
    format!("{}{wgsl}", crate::hash::WGSL)
}
