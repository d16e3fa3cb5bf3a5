//! The voice outputs of a glottal run: `glottal_flow.csv` (the series), `voice.json` (the
//! measures of [`crate::analysis::voice`] and how the sound was made), `pulses.csv`, SVG plots
//! of U_g(t), dU_g/dt and the spectrum, and the sound: `glottal_flow.wav` (U_g, mean removed)
//! and `radiated.wav` (dU_g/dt: the radiated pressure of a monopole at the lips is ∝ dU/dt, a
//! first approximation with no vocal tract), 44.1 kHz 16-bit mono, normalised to 0.9 of full
//! scale, at least one second long. A coupled glottis's series also carries the air's power on
//! the folds: `voice.json` then holds its work per cycle ([`EnergyTransfer`]).

use crate::analysis::closure::ClosureShape;
use crate::analysis::resample::resample;
use crate::analysis::spectrum::amplitude_spectrum;
use crate::analysis::voice::{VoiceMeasures, VoiceOptions, voice_measures};
use crate::output::axis::{tick_label, value_range};
use anyhow::{Context, bail};
use plotters::prelude::*;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Audio sample rate of the WAV files (Hz).
pub const AUDIO_RATE: u32 = 44_100;
/// Shortest sound written (s).
pub const MIN_AUDIO_S: f64 = 1.0;

/// A uniformly sampled glottal series: the flow and, when known, the area and more columns.
#[derive(Clone, Debug, Default)]
pub struct GlottalSeries {
    /// Sample interval (s).
    pub dt: f64,
    /// Glottal volume flow (cm³/s; per unit length, cm²/s, in 2D).
    pub flow: Vec<f64>,
    /// Further columns (name with unit, values), e.g. `area_cm2`.
    pub columns: Vec<(String, Vec<f64>)>,
}

impl GlottalSeries {
    /// The values of the column `name`, when the series has it.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }
}

/// Write `glottal_flow.csv`: `t_s,flow_cm3_s` and the extra columns.
pub fn write_glottal_csv(dir: &Path, s: &GlottalSeries) -> anyhow::Result<PathBuf> {
    let path = dir.join("glottal_flow.csv");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&path)?);
    write!(w, "t_s,flow_cm3_s")?;
    for (n, _) in &s.columns {
        write!(w, ",{n}")?;
    }
    writeln!(w)?;
    for (i, u) in s.flow.iter().enumerate() {
        write!(w, "{:.9e},{u:.9e}", i as f64 * s.dt)?;
        for (_, c) in &s.columns {
            write!(w, ",{:.9e}", c[i])?;
        }
        writeln!(w)?;
    }
    w.flush()?;
    Ok(path)
}

/// Read a `glottal_flow.csv` (the time column `t_s`, the flow column `flow_cm3_s`, any others),
/// checking that the sampling is uniform.
pub fn read_glottal_csv(path: &Path) -> anyhow::Result<GlottalSeries> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().context("empty glottal_flow.csv")?.split(',').map(str::trim).collect();
    let t_col = header.iter().position(|h| *h == "t_s").context("glottal_flow.csv: no `t_s` column")?;
    let u_col = header.iter().position(|h| *h == "flow_cm3_s").context("glottal_flow.csv: no `flow_cm3_s` column")?;
    let mut cols: Vec<Vec<f64>> = vec![Vec::new(); header.len()];
    for (n, line) in lines.enumerate() {
        let vals: Vec<&str> = line.split(',').collect();
        if vals.len() != header.len() {
            bail!("glottal_flow.csv line {}: {} values, the header has {}", n + 2, vals.len(), header.len());
        }
        for (c, v) in vals.iter().enumerate() {
            cols[c].push(v.trim().parse().with_context(|| format!("glottal_flow.csv line {}, column `{}`: not a number", n + 2, header[c]))?);
        }
    }
    let t = &cols[t_col];
    if t.len() < 3 {
        bail!("glottal_flow.csv: {} samples, too few to analyse", t.len());
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    if dt.is_nan() || dt <= 0.0 || t.windows(2).any(|w| ((w[1] - w[0]) / dt - 1.0).abs() > 1e-3) {
        bail!("glottal_flow.csv: the times in `t_s` are not uniformly spaced (the measures need a uniform series)");
    }
    let columns = header.iter().enumerate().filter(|(c, _)| *c != t_col && *c != u_col).map(|(c, h)| (h.to_string(), cols[c].clone())).collect();
    Ok(GlottalSeries { dt, flow: cols[u_col].clone(), columns })
}

/// The columns of the air's power on the folds start with this (then the part's name:
/// `coupling::glottis::AIR_POWER_PARTS`, then `_erg_s`).
pub const AIR_POWER_PREFIX: &str = "air_power_";
/// The margins' lateral displacement columns (cm, positive away from the mid-line).
pub const LOWER_MARGIN_COLUMN: &str = "lower_margin_cm";
pub const UPPER_MARGIN_COLUMN: &str = "upper_margin_cm";
/// The folds' kinetic energy column.
pub const KINETIC_ENERGY_COLUMN: &str = "fold_kinetic_energy_erg";

/// The air's work on the folds over the cycles of the measures' window: from one upward crossing
/// of the glottal area's mean to the next ([`crate::analysis::energy::work_per_cycle`]).
#[derive(Clone, Debug, Serialize)]
pub struct EnergyTransfer {
    /// The parts of the folds' surface, as in the power columns' names.
    pub parts: Vec<String>,
    /// Mean work per cycle of each part (erg): positive where the air feeds the vibration. The
    /// lung pressure's steady push on the inferior part does work too wherever the folds are not
    /// where they were a cycle before: with the area back at its mean, a fold whose vibration
    /// decays or grows still sits a little higher or lower.
    pub work_per_cycle_erg: Vec<f64>,
    /// Their sum (erg).
    pub total_work_per_cycle_erg: f64,
    /// Mean over the cycles of the folds' largest kinetic energy in the cycle (erg).
    pub peak_kinetic_energy_erg: f64,
    /// total_work_per_cycle_erg / peak_kinetic_energy_erg: the fraction of the vibration's
    /// energy the air adds (> 0) or takes (< 0) per cycle.
    pub work_over_peak_kinetic_energy: f64,
    pub per_cycle: Vec<crate::analysis::energy::CycleWork>,
}

/// The air's work per cycle from the power columns of `s`, over the window of `m`; `None`
/// when the series has no power or area columns or no whole cycle fits.
fn energy_transfer(s: &GlottalSeries, m: &VoiceMeasures) -> Option<EnergyTransfer> {
    let power: Vec<(&str, &[f64])> =
        s.columns.iter().filter_map(|(n, v)| Some((n.strip_prefix(AIR_POWER_PREFIX)?.trim_end_matches("_erg_s"), v.as_slice()))).collect();
    let ke = s.column(KINETIC_ENERGY_COLUMN)?;
    let [a, b, c] = power.as_slice() else { return None };
    let area = s.column("area_cm2")?;
    let start = ((m.window_s[0] / s.dt) as usize).min(area.len());
    let window = &area[start..];
    let mean = window.iter().sum::<f64>() / window.len().max(1) as f64;
    let bounds: Vec<f64> = crate::analysis::oscillation::upward_crossings(window, mean, s.dt).iter().map(|t| t + start as f64 * s.dt).collect();
    let w = crate::analysis::energy::work_per_cycle([a.1, b.1, c.1], ke, s.dt, &bounds);
    if w.is_empty() {
        return None;
    }
    let n = w.len() as f64;
    let work_per_cycle_erg: Vec<f64> = (0..3).map(|k| w.iter().map(|p| p.work[k]).sum::<f64>() / n).collect();
    let total: f64 = work_per_cycle_erg.iter().sum();
    let peak = w.iter().map(|p| p.peak_kinetic_energy).sum::<f64>() / n;
    Some(EnergyTransfer {
        parts: [a.0, b.0, c.0].map(String::from).to_vec(),
        work_per_cycle_erg,
        total_work_per_cycle_erg: total,
        peak_kinetic_energy_erg: peak,
        work_over_peak_kinetic_energy: total / peak,
        per_cycle: w,
    })
}

/// The medial surface's shape at the closing instants of the measures' pulses (their `t_close`:
/// a closure, or where the flow of a glottis that stays open comes back to its cycle's minimum), from
/// the margins' columns ([`crate::analysis::closure::shape_at_closures`]); `None` without them.
fn closure_shape(s: &GlottalSeries, m: &VoiceMeasures) -> Option<ClosureShape> {
    let closures: Vec<f64> = m.pulse_list.iter().map(|p| p.t_close).collect();
    crate::analysis::closure::shape_at_closures(s.column(LOWER_MARGIN_COLUMN)?, s.column(UPPER_MARGIN_COLUMN)?, s.dt, &closures)
}

/// The vertical phase difference of the margins over the voice window: the lower margin's
/// fundamental against the upper one's at f0 ([`crate::analysis::lag::phase_lead`]; positive
/// when the lower margin moves first, as in a mucosal wave); `None` without the margins'
/// columns or where they do not move at f0.
fn vertical_phase(s: &GlottalSeries, m: &VoiceMeasures) -> Option<crate::analysis::lag::PhaseLead> {
    let start = ((m.window_s[0] / s.dt).round() as usize).min(s.flow.len());
    let (lower, upper) = (s.column(LOWER_MARGIN_COLUMN)?, s.column(UPPER_MARGIN_COLUMN)?);
    crate::analysis::lag::phase_lead(lower.get(start..)?, upper.get(start..)?, s.dt, m.f0_autocorrelation_hz)
}

/// How the sound files were made.
#[derive(Clone, Debug, Serialize)]
pub struct AudioNote {
    pub sample_rate_hz: u32,
    pub seconds: f64,
    /// "the whole run", or which periods were repeated to reach the length.
    pub source: String,
}

/// What [`write_voice_outputs`] wrote.
#[derive(Clone, Debug, Serialize)]
pub struct VoiceReport {
    pub measures: Option<VoiceMeasures>,
    /// Why there are no measures (no oscillation, too short).
    pub no_voice: Option<String>,
    pub audio: AudioNote,
    /// The air's work on the folds per cycle, when the series carries their power.
    pub energy: Option<EnergyTransfer>,
    /// Where the glottis closes, when the series carries the margins.
    pub closure: Option<ClosureShape>,
    /// The margins' vertical phase difference, when the series carries them.
    pub vertical_phase: Option<crate::analysis::lag::PhaseLead>,
    pub files: Vec<PathBuf>,
}

/// What [`glottal_measures`] reads from a series.
pub struct GlottalMeasures {
    pub measures: Option<VoiceMeasures>,
    /// Why there are no measures (no oscillation, too short).
    pub no_voice: Option<String>,
    /// The air's work on the folds per cycle, when the series carries their power.
    pub energy: Option<EnergyTransfer>,
    /// Where the glottis closes, when the series carries the margins.
    pub closure: Option<ClosureShape>,
    /// The margins' vertical phase difference, when the series carries them.
    pub vertical_phase: Option<crate::analysis::lag::PhaseLead>,
}

/// The voice measures of `s` over the window of `opts`, with the air's work per cycle and the
/// closure shape where the series has their columns: what voice.json holds, without writing.
pub fn glottal_measures(s: &GlottalSeries, opts: &VoiceOptions) -> GlottalMeasures {
    let (measures, no_voice) = match voice_measures(&s.flow, s.dt, opts) {
        Ok(m) => (Some(m), None),
        Err(e) => (None, Some(e.to_string())),
    };
    let energy = measures.as_ref().and_then(|m| energy_transfer(s, m));
    let closure = measures.as_ref().and_then(|m| closure_shape(s, m));
    let vertical_phase = measures.as_ref().and_then(|m| vertical_phase(s, m));
    GlottalMeasures { measures, no_voice, energy, closure, vertical_phase }
}

/// Measure the series and write `voice.json` (with `extra` merged in: the scene, the two-mass
/// yardstick, …), `pulses.csv`, the plots and the WAV files into `dir`.
pub fn write_voice_outputs(dir: &Path, s: &GlottalSeries, opts: &VoiceOptions, extra: serde_json::Value) -> anyhow::Result<VoiceReport> {
    let GlottalMeasures { measures, no_voice, energy, closure, vertical_phase } = glottal_measures(s, opts);
    let derivative: Vec<f64> = s.flow.windows(2).map(|w| (w[1] - w[0]) / s.dt).collect();
    let mut files = Vec::new();
    let audio = write_wavs(dir, s, &derivative, measures.as_ref(), &mut files)?;
    if let Some(m) = &measures {
        let path = dir.join("pulses.csv");
        let mut text = String::from("t_open_s,t_peak_s,t_close_s,period_s,peak_flow_cm3_s,ac_flow_cm3_s,mfdr_cm3_s2\n");
        for p in &m.pulse_list {
            text += &format!("{:.9e},{:.9e},{:.9e},{:.9e},{:.6e},{:.6e},{:.6e}\n", p.t_open, p.t_peak, p.t_close, p.period, p.peak_flow, p.ac_flow, p.mfdr);
        }
        std::fs::write(&path, text)?;
        files.push(path);
    }
    files.extend(plot_series(dir, s, &derivative, measures.as_ref(), opts.window_fraction)?);
    let mut json = serde_json::json!({
        "oscillating": measures.is_some(),
        "measures": measures,
        "aerodynamic_energy_transfer": energy,
        "closure_shape": closure,
        "vertical_phase": vertical_phase,
        "no_voice": no_voice,
        "sample_rate_hz": 1.0 / s.dt,
        "samples": s.flow.len(),
        "audio": audio,
        "options": opts,
        "definitions": DEFINITIONS,
    });
    if let (Some(obj), serde_json::Value::Object(more)) = (json.as_object_mut(), extra) {
        obj.extend(more);
    }
    let path = dir.join("voice.json");
    std::fs::write(&path, serde_json::to_string_pretty(&json)?)?;
    files.insert(0, path);
    Ok(VoiceReport { measures, no_voice, audio, energy, closure, vertical_phase, files })
}

/// The definitions the measures follow, written into voice.json (see `analysis::voice`).
pub const DEFINITIONS: &str = "APARAT-style: window = last window_fraction of the run; f0 by autocorrelation (parabolic refinement), \
f0_spectrum by the Hann-windowed spectrum peak; pulses = flow maxima ≥ 0.7 T0 apart; opening at the rising 20 % crossing of the pulse's rise, \
closure at the return to within 1 % of the closed-phase level; OQ = (t_c − t_o)/T0, SQ = (t_peak − t_o)/(t_c − t_peak), ClQ = (t_c − t_peak)/T0, \
QOQ = time above 50 % of A_ac / T0; MFDR = −min dU/dt; NAQ = A_ac/(MFDR·T0); H1–H2 of dU/dt by projection over whole periods; \
means over the pulses of the window; aerodynamic_energy_transfer = ∫ Σ F·v dt over the folds' surface particles per cycle \
of the window, from one upward crossing of the glottal area's window mean to the next (Thomson, Mongeau & Frankel 2005), by part of the surface (below the lower margin, between the margins, above the upper one); \
closure_shape = the margins' lateral displacements at each pulse's closure instant (as for OQ: a closure, or the most closed instant of a cycle whose glottis stays open): lower − upper < 0 is a divergent glottis closing from below (the lower margin nearer the mid-line), > 0 a convergent one closing from above";

/// Write the two WAV files; the audio is the whole run when it lasts a second or more, else the
/// last whole periods (between pulse peaks) repeated.
fn write_wavs(dir: &Path, s: &GlottalSeries, derivative: &[f64], m: Option<&VoiceMeasures>, files: &mut Vec<PathBuf>) -> anyhow::Result<AudioNote> {
    let duration = s.flow.len() as f64 * s.dt;
    let fs_in = 1.0 / s.dt;
    let n_out = ((duration.max(MIN_AUDIO_S)) * AUDIO_RATE as f64).ceil() as usize;
    // the segment of whole periods to loop: the last pulses' peaks (at most 10 periods)
    let periodic_segment = m.filter(|_| duration < MIN_AUDIO_S).and_then(|m| {
        let peaks: Vec<usize> = m.pulse_list.iter().map(|p| (p.t_peak / s.dt).round() as usize).collect();
        let last = *peaks.last()?;
        let first = peaks[peaks.len().saturating_sub(11)];
        (last > first).then_some((first, last, peaks.len().min(11) - 1))
    });
    let (flow_audio, deriv_audio, source) = match periodic_segment {
        Some((a, b, periods)) => {
            let seg = &s.flow[a..b];
            let dseg = &derivative[a..b];
            let repeats = MIN_AUDIO_S / ((b - a) as f64 * s.dt);
            (
                resample(&demean(seg), fs_in, AUDIO_RATE as f64, n_out, true),
                resample(dseg, fs_in, AUDIO_RATE as f64, n_out, true),
                format!(
                    "the run lasts {duration:.3} s: its last {periods} whole periods ({:.4}–{:.4} s) repeated {repeats:.1} times to reach {MIN_AUDIO_S} s",
                    a as f64 * s.dt,
                    b as f64 * s.dt
                ),
            )
        }
        None => {
            let note = if duration < MIN_AUDIO_S {
                let why = if m.is_some() { "has fewer than two whole periods in the analysed window to repeat" } else { "does not oscillate" };
                format!("the run lasts {duration:.3} s and {why}: the whole run, then silence up to {MIN_AUDIO_S} s")
            } else {
                "the whole run".to_string()
            };
            (resample(&demean(&s.flow), fs_in, AUDIO_RATE as f64, n_out, false), resample(derivative, fs_in, AUDIO_RATE as f64, n_out, false), note)
        }
    };
    for (name, data) in [("glottal_flow.wav", &flow_audio), ("radiated.wav", &deriv_audio)] {
        let path = dir.join(name);
        write_wav(&path, data)?;
        files.push(path);
    }
    Ok(AudioNote { sample_rate_hz: AUDIO_RATE, seconds: n_out as f64 / AUDIO_RATE as f64, source })
}

fn demean(x: &[f64]) -> Vec<f64> {
    let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter().map(|v| v - m).collect()
}

/// 16-bit mono PCM at [`AUDIO_RATE`], peak normalised to 0.9 of full scale (silence stays 0).
pub fn write_wav(path: &Path, data: &[f64]) -> anyhow::Result<()> {
    let spec = hound::WavSpec { channels: 1, sample_rate: AUDIO_RATE, bits_per_sample: 16, sample_format: hound::SampleFormat::Int };
    let mut w = hound::WavWriter::create(path, spec).with_context(|| format!("creating {}", path.display()))?;
    let peak = data.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let scale = if peak > 0.0 { 0.9 * i16::MAX as f64 / peak } else { 0.0 };
    for v in data {
        w.write_sample((v * scale).round() as i16)?;
    }
    w.finalize()?;
    Ok(())
}

/// `glottal_flow.svg` (U_g and the area when present), `flow_derivative.svg`, `spectrum.svg`
/// (dU_g/dt in dB, with f0 and its harmonics marked).
fn plot_series(dir: &Path, s: &GlottalSeries, derivative: &[f64], m: Option<&VoiceMeasures>, window_fraction: f64) -> anyhow::Result<Vec<PathBuf>> {
    // The last 10 periods (or the last 50 ms) in the time plots, thinned to ≤ 4000 points.
    let span = m.map_or(0.05, |m| 10.0 / m.f0_autocorrelation_hz);
    let n = s.flow.len();
    let start = n.saturating_sub((span / s.dt) as usize);
    let thin = ((n - start) / 4000).max(1);
    let pts = |x: &[f64]| -> Vec<(f64, f64)> { (start..x.len()).step_by(thin).map(|i| (i as f64 * s.dt * 1e3, x[i])).collect() };
    let mut out = Vec::new();
    let title = match m {
        Some(m) => format!("glottal flow: f0 {:.1} Hz, OQ {:.2}, peak {:.0} cm³/s", m.f0_autocorrelation_hz, m.open_quotient, m.peak_flow),
        None => "glottal flow (no steady oscillation)".to_string(),
    };
    out.push(line_plot(&dir.join("glottal_flow.svg"), &title, "t (ms)", "U_g (cm³/s)", &pts(&s.flow))?);
    let dtitle = match m {
        Some(m) => format!("flow derivative: MFDR {:.3e} cm³/s², NAQ {:.3}", m.mfdr, m.naq),
        None => "flow derivative".to_string(),
    };
    out.push(line_plot(&dir.join("flow_derivative.svg"), &dtitle, "t (ms)", "dU_g/dt (cm³/s²)", &pts(derivative))?);
    // spectrum of the analysed window's derivative, 0–5 kHz, dB re its maximum
    let window = (n as f64 * window_fraction) as usize;
    let spec = amplitude_spectrum(&derivative[derivative.len().saturating_sub(window)..], s.dt, 2);
    let top = spec.iter().fold(0.0f64, |a, p| a.max(p.1)).max(1e-300);
    let db: Vec<(f64, f64)> = spec.iter().filter(|p| p.0 <= 5000.0).map(|p| (p.0, 20.0 * (p.1 / top).max(1e-6).log10())).collect();
    let stitle = match m {
        Some(m) => format!("spectrum of dU_g/dt: H1–H2 {:.1} dB", m.h1_h2_db),
        None => "spectrum of dU_g/dt".to_string(),
    };
    out.push(line_plot(&dir.join("spectrum.svg"), &stitle, "f (Hz)", "level (dB re max)", &db)?);
    Ok(out)
}

fn line_plot(path: &Path, title: &str, x_desc: &str, y_desc: &str, pts: &[(f64, f64)]) -> anyhow::Result<PathBuf> {
    let root = SVGBackend::new(path, (800, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let (x0, x1) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let (x0, x1) = if x0 < x1 { (x0, x1) } else { (0.0, 1.0) };
    let (y0, y1) = value_range(y0, y1);
    let mut chart =
        ChartBuilder::on(&root).caption(title, ("sans-serif", 18)).margin(12).x_label_area_size(40).y_label_area_size(70).build_cartesian_2d(x0..x1, y0..y1)?;
    let (xspan, yspan) = (x1 - x0, y1 - y0);
    chart.configure_mesh().x_desc(x_desc).y_desc(y_desc).x_label_formatter(&|v| tick_label(*v, xspan)).y_label_formatter(&|v| tick_label(*v, yspan)).draw()?;
    chart.draw_series(LineSeries::new(pts.iter().cloned(), BLUE.stroke_width(1)))?;
    root.present()?;
    Ok(path.to_path_buf())
}

/// `phonation analyze DIR`: read `DIR/glottal_flow.csv` and (re)write the voice outputs, with
/// `extra` (an object) merged into voice.json.
pub fn analyze_dir(dir: &Path, opts: &VoiceOptions, extra: serde_json::Value) -> anyhow::Result<VoiceReport> {
    let s = read_glottal_csv(&dir.join("glottal_flow.csv"))?;
    let mut more = serde_json::json!({ "analysed_from": dir.join("glottal_flow.csv") });
    if let (Some(m), serde_json::Value::Object(e)) = (more.as_object_mut(), extra) {
        m.extend(e);
    }
    write_voice_outputs(dir, &s, opts, more)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glottal series carrying the air's power (a Rosenberg pulse train, the area following
    /// the flow): voice.json's `aerodynamic_energy_transfer` integrates each part over the
    /// cycles between the area's upward mean crossings — one per pulse — and divides by the
    /// peak kinetic energy. Powers: inferior P₀ + B cos(2π f0 t) (work P₀T a cycle), medial 0,
    /// superior −P₁ (work −P₁T); the kinetic energy K + K' sin²(π f0 t) (peak K + K'). The
    /// margins: the lower one 20 µm in, the upper one 10 µm out and drifting out at 0.01 cm/s,
    /// so `closure_shape` reads −(0.003 + 0.01 t_c) cm at every pulse's closure t_c.
    #[test]
    fn voice_json_holds_the_airs_work_per_cycle() {
        let r = crate::analysis::synthetic::Rosenberg { f0: 125.0, opening: 0.0032, closing: 0.0016, amplitude: 300.0, baseline: 0.0 };
        let (dt, n) = (2.0e-5, 4000);
        let t0 = 1.0 / r.f0;
        let (p0, b, p1, k, k2) = (3000.0, 40000.0, 1000.0, 150.0, 50.0);
        let t = |i: usize| i as f64 * dt;
        let flow = r.sample(dt, n);
        let col = |name: &str, f: &dyn Fn(f64) -> f64| (name.to_string(), (0..n).map(|i| f(t(i))).collect::<Vec<f64>>());
        let series = GlottalSeries {
            dt,
            flow: flow.clone(),
            columns: vec![
                ("area_cm2".into(), flow.iter().map(|u| u / 3000.0).collect()),
                col("air_power_inferior_erg_s", &|t| p0 + b * (2.0 * std::f64::consts::PI * r.f0 * t).cos()),
                col("air_power_medial_erg_s", &|_| 0.0),
                col("air_power_superior_erg_s", &|_| -p1),
                col(KINETIC_ENERGY_COLUMN, &|t| k + k2 * (std::f64::consts::PI * r.f0 * t).sin().powi(2)),
                col(LOWER_MARGIN_COLUMN, &|_| -0.002),
                col(UPPER_MARGIN_COLUMN, &|t| 0.001 + 0.01 * t),
            ],
        };
        let dir = std::env::temp_dir().join(format!("phonation_voice_energy_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let report = write_voice_outputs(&dir, &series, &VoiceOptions::default(), serde_json::json!({})).unwrap();
        let e = report.energy.expect("an energy transfer");
        // the last half of 80 ms at 125 Hz: five pulses, four cycles between their crossings
        assert_eq!(e.per_cycle.len(), 4, "{:?}", e.per_cycle.iter().map(|c| (c.t_start, c.t_end)).collect::<Vec<_>>());
        assert_eq!(e.parts, ["inferior", "medial", "superior"]);
        for c in &e.per_cycle {
            assert!(((c.t_end - c.t_start) / t0 - 1.0).abs() < 1e-6);
        }
        assert!((e.work_per_cycle_erg[0] / (p0 * t0) - 1.0).abs() < 1e-3, "{:?}", e.work_per_cycle_erg);
        assert_eq!(e.work_per_cycle_erg[1], 0.0);
        assert!((e.work_per_cycle_erg[2] / (-p1 * t0) - 1.0).abs() < 1e-9);
        assert!((e.peak_kinetic_energy_erg / (k + k2) - 1.0).abs() < 1e-3);
        assert!((e.work_over_peak_kinetic_energy / ((p0 - p1) * t0 / (k + k2)) - 1.0).abs() < 2e-3);
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("voice.json")).unwrap()).unwrap();
        assert_eq!(json["aerodynamic_energy_transfer"]["total_work_per_cycle_erg"].as_f64(), Some(e.total_work_per_cycle_erg));
        let m = report.measures.expect("measures");
        let c = report.closure.expect("a closure shape");
        assert_eq!((c.closures, c.from_below), (m.pulse_list.len(), 1.0));
        assert!(c.closures >= 3, "{} closures", c.closures);
        for (d, p) in c.per_closure.iter().zip(&m.pulse_list) {
            assert!((d + 0.003 + 0.01 * p.t_close).abs() < 1e-12, "{d} at {}", p.t_close);
        }
        assert_eq!(json["closure_shape"]["from_below"].as_f64(), Some(1.0));
        // a lower margin that does not move has no phase
        assert!(report.vertical_phase.is_none());
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Margins that swing at f0, the lower one 60° ahead of the upper one (a mucosal wave):
    /// voice.json's `vertical_phase` reads 60° within 1 % over the voice window's whole periods,
    /// the lead 60/360 of a period and the two fundamentals' amplitudes.
    #[test]
    fn voice_json_holds_the_margins_vertical_phase() {
        let r = crate::analysis::synthetic::Rosenberg { f0: 125.0, opening: 0.0032, closing: 0.0016, amplitude: 300.0, baseline: 0.0 };
        let (dt, n) = (2.0e-5, 4000);
        let w = 2.0 * std::f64::consts::PI * r.f0;
        let flow = r.sample(dt, n);
        let col = |name: &str, f: &dyn Fn(f64) -> f64| (name.to_string(), (0..n).map(|i| f(i as f64 * dt)).collect::<Vec<f64>>());
        let series = GlottalSeries {
            dt,
            flow,
            columns: vec![
                col(LOWER_MARGIN_COLUMN, &|t| 0.002 * (w * t + 60f64.to_radians()).cos()),
                col(UPPER_MARGIN_COLUMN, &|t| 0.004 * (w * t).cos() + 0.001),
            ],
        };
        let dir = std::env::temp_dir().join(format!("phonation_voice_phase_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let report = write_voice_outputs(&dir, &series, &VoiceOptions::default(), serde_json::json!({})).unwrap();
        let m = report.measures.expect("measures");
        let v = report.vertical_phase.expect("a vertical phase");
        assert!((v.degrees - 60.0).abs() < 0.6, "{} degrees", v.degrees);
        assert!((v.lead_s - v.degrees / 360.0 / m.f0_autocorrelation_hz).abs() < 1e-15);
        assert!((v.amplitudes[0] - 0.002).abs() < 2e-5 && (v.amplitudes[1] - 0.004).abs() < 4e-5, "{:?}", v.amplitudes);
        assert!(v.periods >= 4, "{} periods", v.periods);
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("voice.json")).unwrap()).unwrap();
        assert_eq!(json["vertical_phase"]["degrees"].as_f64(), Some(v.degrees));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The SVG's axis labels of a closed glottis (U_g = 0 throughout) and of a flow derivative
    /// of 10⁶ cm³/s²: short, and zero printed as 0.
    #[test]
    fn plots_of_a_zero_flow_and_of_a_large_derivative_have_short_labels() {
        let dir = std::env::temp_dir().join(format!("phonation_voice_plot_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (name, scale) in [("zero", 0.0), ("large", 9.3e5)] {
            let pts: Vec<(f64, f64)> = (0..400).map(|i| (445.0 + 0.125 * i as f64, scale * (0.05 * i as f64).sin())).collect();
            let path = line_plot(&dir.join(format!("{name}.svg")), "t", "t (ms)", "v", &pts).unwrap();
            let svg = std::fs::read_to_string(path).unwrap().replace('\n', " ");
            let labels: Vec<String> =
                svg.split("<text").skip(1).filter_map(|t| t.split_once('>').map(|(_, r)| r.split("</text>").next().unwrap_or("").trim().to_string())).collect();
            let ticks: Vec<&String> = labels.iter().filter(|l| l.parse::<f64>().is_ok()).collect();
            assert!(ticks.len() >= 10, "{name}: {labels:?}");
            assert!(ticks.iter().all(|l| l.len() <= 6), "{name}: {ticks:?}");
            assert!(ticks.iter().any(|l| l.as_str() == "0"), "{name}: zero is labelled 0: {ticks:?}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
