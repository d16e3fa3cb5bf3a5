//! Checkpoint files: a run's complete state at a step, written atomically, so that a run
//! stopped at any point continues bit for bit (`phonation run SCENE --checkpoint-every N`,
//! then `phonation run --resume DIR/checkpoint.bin`).
//!
//! Layout (little-endian):
//!
//! | bytes | what |
//! |---|---|
//! | 8 | magic `PHONCKPT` |
//! | 4 | format version ([`FORMAT_VERSION`]) |
//! | 32 | scene hash: BLAKE3 of the scene's canonical form (keys sorted, numbers by their bits: comments and layout do not count) |
//! | 8 | step |
//! | 8 × 3 | lengths of the scene text, of the run record and of the solver state |
//! | … | the scene text (a resume needs no scene file), the run record (JSON: what the run loop carries from step to step — initial totals, samples for the final analysis, output files and their lengths), the solver state ([`crate::state`]) |
//! | 32 | checksum: BLAKE3 of everything before it |
//!
//! A resume refuses, before it touches the output directory: a file that is not a checkpoint,
//! another format version, a truncated or damaged file (checksum), a checkpoint of another
//! scene (hash), and a state that does not fit the scene's solver (section names and lengths).
//! Output files (CSV series) are cut back to their length at the checkpoint, so rows written
//! after it by the interrupted run are not repeated.

use crate::state::{SaveState, StateError, StateReader, StateWriter};
use serde_json::{Value, json};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The checkpoint format this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;
/// The file name in the output directory (the latest checkpoint replaces the previous one).
pub const FILE_NAME: &str = "checkpoint.bin";
const MAGIC: [u8; 8] = *b"PHONCKPT";
/// Magic, version, scene hash, step and three lengths.
const HEADER: usize = 8 + 4 + 32 + 8 + 3 * 8;

/// Why a checkpoint cannot be read or does not fit.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: not a phonation checkpoint (it does not start with PHONCKPT)")]
    NotACheckpoint { path: PathBuf },
    #[error("{path}: checkpoint format version {found}; this phonation reads version {expected} only")]
    Version { path: PathBuf, found: u32, expected: u32 },
    #[error("{path}: truncated ({len} bytes, its header announces {needed})")]
    Truncated { path: PathBuf, len: u64, needed: u64 },
    #[error("{path}: checksum mismatch (the file is damaged)")]
    Checksum { path: PathBuf },
    #[error(
        "{path}: a checkpoint of another scene (scene hash {found} ≠ {given} of the scene given); resume with the scene it was written from, or give no scene"
    )]
    OtherScene { path: PathBuf, found: String, given: String },
    #[error("{path}: {source}")]
    State { path: PathBuf, source: StateError },
    #[error("{path}: the run record: {reason}")]
    Record { path: PathBuf, reason: String },
}

/// One checkpoint.
#[derive(Clone, Debug)]
pub struct Checkpoint {
    /// Where it was read from (empty when built in memory).
    pub path: PathBuf,
    pub scene_text: String,
    pub scene_hash: [u8; 32],
    /// The run's step (the solver's step counter) at the checkpoint.
    pub step: u64,
    /// The run loop's record (JSON).
    pub run: Value,
    /// The solver's state ([`SaveState`]).
    pub state: Vec<u8>,
}

impl Checkpoint {
    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let run = serde_json::to_vec(&self.run).expect("JSON values serialise");
        let mut b = Vec::with_capacity(HEADER + self.scene_text.len() + run.len() + self.state.len() + 32);
        b.extend_from_slice(&MAGIC);
        b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        b.extend_from_slice(&self.scene_hash);
        b.extend_from_slice(&self.step.to_le_bytes());
        for len in [self.scene_text.len(), run.len(), self.state.len()] {
            b.extend_from_slice(&(len as u64).to_le_bytes());
        }
        b.extend_from_slice(self.scene_text.as_bytes());
        b.extend_from_slice(&run);
        b.extend_from_slice(&self.state);
        let sum = blake3::hash(&b);
        b.extend_from_slice(sum.as_bytes());
        b
    }

    /// Writes to `path` atomically: a temporary file beside it, synced, then renamed over it, so
    /// that a run killed while writing leaves the previous checkpoint intact.
    pub fn write_atomic(&self, path: &Path) -> std::io::Result<()> {
        let tmp = path.with_extension("bin.tmp");
        {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(&self.to_bytes())?;
            f.sync_all()?;
        }
        std::fs::rename(&tmp, path)
    }

    /// Reads and checks a checkpoint file (magic, version, length, checksum).
    pub fn read(path: &Path) -> Result<Self, CheckpointError> {
        let bytes = std::fs::read(path).map_err(|source| CheckpointError::Io { path: path.into(), source })?;
        Self::from_bytes(&bytes, path)
    }

    pub fn from_bytes(b: &[u8], path: &Path) -> Result<Self, CheckpointError> {
        let path = path.to_path_buf();
        if b.len() < 8 || b[..8] != MAGIC {
            return Err(CheckpointError::NotACheckpoint { path });
        }
        let truncated = |needed: u64| CheckpointError::Truncated { path: path.clone(), len: b.len() as u64, needed };
        if b.len() < HEADER {
            return Err(truncated(HEADER as u64 + 32));
        }
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().unwrap());
        let version = u32::from_le_bytes(b[8..12].try_into().unwrap());
        if version != FORMAT_VERSION {
            return Err(CheckpointError::Version { path, found: version, expected: FORMAT_VERSION });
        }
        let scene_hash: [u8; 32] = b[12..44].try_into().unwrap();
        let step = u64_at(44);
        let lens = [u64_at(52), u64_at(60), u64_at(68)];
        let needed = lens.iter().try_fold(HEADER as u64 + 32, |a, &l| a.checked_add(l)).unwrap_or(u64::MAX);
        if (b.len() as u64) < needed {
            return Err(truncated(needed));
        }
        if b.len() as u64 > needed {
            return Err(CheckpointError::Checksum { path });
        }
        let body = &b[..b.len() - 32];
        if blake3::hash(body).as_bytes() != &b[b.len() - 32..] {
            return Err(CheckpointError::Checksum { path });
        }
        let (l0, l1) = (lens[0] as usize, lens[1] as usize);
        let text = &body[HEADER..HEADER + l0];
        let run = &body[HEADER + l0..HEADER + l0 + l1];
        let state = body[HEADER + l0 + l1..].to_vec();
        let record = |reason: String| CheckpointError::Record { path: path.clone(), reason };
        let scene_text = String::from_utf8(text.to_vec()).map_err(|e| record(format!("scene text: {e}")))?;
        let run = serde_json::from_slice(run).map_err(|e| record(e.to_string()))?;
        Ok(Self { path, scene_text, scene_hash, step, run, state })
    }

    /// Refuses a checkpoint of another scene than `scene_text`.
    pub fn check_scene(&self, scene_text: &str) -> Result<(), CheckpointError> {
        let given = scene_hash(scene_text);
        if given != self.scene_hash {
            return Err(CheckpointError::OtherScene { path: self.path.clone(), found: hex(&self.scene_hash[..6]), given: hex(&given[..6]) });
        }
        Ok(())
    }

    /// Restores `solver` (built from the same scene) from the saved state.
    pub fn restore(&self, solver: &mut impl SaveState) -> Result<(), CheckpointError> {
        let mut r = StateReader::new(&self.state);
        let state = |source| CheckpointError::State { path: self.path.clone(), source };
        solver.load_state(&mut r).map_err(state)?;
        r.finish().map_err(state)
    }

    /// The run record's `key`.
    pub fn record(&self, key: &str) -> Result<&Value, CheckpointError> {
        self.run.get(key).ok_or_else(|| CheckpointError::Record { path: self.path.clone(), reason: format!("no `{key}`") })
    }
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// BLAKE3 of the scene's canonical form: tables with sorted keys, floats by their bits, so
/// that comments, whitespace and key order do not change it. Text that is not TOML hashes as
/// it is (the scene reader refuses it anyway).
pub fn scene_hash(text: &str) -> [u8; 32] {
    match text.parse::<toml::Table>() {
        Ok(t) => {
            let mut s = String::new();
            canonical(&toml::Value::Table(t), &mut s);
            *blake3::hash(s.as_bytes()).as_bytes()
        }
        Err(_) => *blake3::hash(text.as_bytes()).as_bytes(),
    }
}

fn canonical(v: &toml::Value, out: &mut String) {
    use std::fmt::Write;
    match v {
        toml::Value::String(s) => write!(out, "s{}:{s}", s.len()).unwrap(),
        toml::Value::Integer(i) => write!(out, "i{i};").unwrap(),
        toml::Value::Float(f) => write!(out, "f{:x};", f.to_bits()).unwrap(),
        toml::Value::Boolean(b) => write!(out, "b{b};").unwrap(),
        toml::Value::Datetime(d) => write!(out, "d{d};").unwrap(),
        toml::Value::Array(a) => {
            write!(out, "[{}:", a.len()).unwrap();
            a.iter().for_each(|x| canonical(x, out));
            out.push(']');
        }
        toml::Value::Table(t) => {
            let mut keys: Vec<&String> = t.keys().collect();
            keys.sort();
            write!(out, "{{{}:", keys.len()).unwrap();
            for k in keys {
                write!(out, "k{}:{k}", k.len()).unwrap();
                canonical(&t[k], out);
            }
            out.push('}');
        }
    }
}

/// What a run loop needs to write checkpoints and to continue from one.
#[derive(Clone, Debug, Default)]
pub struct Checkpointing {
    /// Write `DIR/checkpoint.bin` every this many steps (None: never).
    pub every: Option<u64>,
    /// Continue from this checkpoint (already checked against the scene).
    pub resume: Option<Checkpoint>,
    /// The scene's text, embedded in each checkpoint (required with `every`).
    pub scene_text: String,
}

impl Checkpointing {
    /// The driver period of the checkpoints (0: none): `every`, else the resumed run's own.
    pub fn period(&self) -> u64 {
        self.every.or_else(|| self.resume.as_ref().and_then(|c| c.run.get("checkpoint_every")?.as_u64())).unwrap_or(0)
    }

    /// Whether this run writes checkpoints.
    pub fn writes(&self) -> bool {
        self.period() > 0
    }

    /// Refuses a period of 0 and a plan without the scene text, before the run allocates.
    pub fn validate(&self) -> anyhow::Result<()> {
        if self.every == Some(0) {
            anyhow::bail!("--checkpoint-every: must be at least 1 step");
        }
        if self.writes() && self.scene_text.is_empty() {
            anyhow::bail!("--checkpoint-every: the run needs the scene's text to embed in its checkpoints");
        }
        Ok(())
    }

    /// Restores `solver` from the checkpoint, if resuming, and cuts the output files the record
    /// lists back to their length at the checkpoint. Returns the record.
    pub fn restore(&self, solver: &mut impl SaveState, dir: &Path) -> anyhow::Result<Option<&Value>> {
        let Some(ck) = &self.resume else { return Ok(None) };
        ck.restore(solver)?;
        let outputs = ck.record("outputs")?.as_array().cloned().unwrap_or_default();
        // check every file first: nothing is cut unless all of them can be
        let mut cuts = Vec::new();
        for o in &outputs {
            let (Some(name), Some(len)) = (o[0].as_str(), o[1].as_u64()) else {
                anyhow::bail!(CheckpointError::Record { path: ck.path.clone(), reason: format!("output entry {o}") });
            };
            let path = dir.join(name);
            let have = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
            if have < len {
                anyhow::bail!(
                    "--resume: {} holds {have} bytes, {len} at the checkpoint; resume into the output directory the checkpoint was written in (--out)",
                    path.display()
                );
            }
            cuts.push((path, len));
        }
        for (path, len) in cuts {
            std::fs::OpenOptions::new().write(true).open(&path)?.set_len(len)?;
        }
        Ok(Some(&ck.run))
    }

    /// The run's last step: `steps` when given, else the resumed run's own (so that its output
    /// schedule stays the same), else the scene's.
    pub fn total(&self, steps: Option<u64>, scene: u64) -> u64 {
        steps.or_else(|| self.resume.as_ref().and_then(|c| c.run.get("total")?.as_u64())).unwrap_or(scene)
    }

    /// Writes `DIR/checkpoint.bin` with `solver`'s state at `step` of a run of `total` steps and
    /// the run's `record`, to which the current lengths of `outputs` (files in `dir`, flushed)
    /// are added.
    pub fn save(&self, dir: &Path, step: u64, total: u64, solver: &impl SaveState, mut record: Value, outputs: &[&str]) -> anyhow::Result<PathBuf> {
        record["total"] = json!(total);
        record["checkpoint_every"] = json!(self.period());
        let mut lens = Vec::new();
        for name in outputs {
            lens.push(json!([name, std::fs::metadata(dir.join(name))?.len()]));
        }
        record["outputs"] = Value::Array(lens);
        let mut w = StateWriter::new();
        solver.save_state(&mut w);
        let ck = Checkpoint {
            path: PathBuf::new(),
            scene_hash: scene_hash(&self.scene_text),
            scene_text: self.scene_text.clone(),
            step,
            run: record,
            state: w.into_bytes(),
        };
        let path = dir.join(FILE_NAME);
        ck.write_atomic(&path)?;
        Ok(path)
    }
}

/// A CSV output: created (and its header written by the caller) on a fresh run, opened for
/// appending on a resumed one.
pub(crate) fn output_file(path: &Path, resumed: bool) -> std::io::Result<std::fs::File> {
    if resumed { std::fs::OpenOptions::new().append(true).open(path) } else { std::fs::File::create(path) }
}

/// f64 values in a run record, by their bits (JSON numbers would round).
pub(crate) fn bits(v: &[f64]) -> Value {
    Value::Array(v.iter().map(|x| json!(x.to_bits())).collect())
}

/// The f64 values of a record entry written by [`bits`].
pub(crate) fn from_bits(v: &Value, what: &str) -> anyhow::Result<Vec<f64>> {
    v.as_array()
        .and_then(|a| a.iter().map(|x| x.as_u64().map(f64::from_bits)).collect::<Option<Vec<_>>>())
        .ok_or_else(|| anyhow::anyhow!("checkpoint run record: `{what}` is not a list of f64 bit patterns"))
}

/// The file names of `files` as a run record lists them (the inverse of [`names`]).
pub(crate) fn file_names<'a>(files: impl IntoIterator<Item = &'a PathBuf>) -> Value {
    Value::Array(files.into_iter().filter_map(|f| f.file_name()).map(|f| json!(f.to_string_lossy())).collect())
}

/// Output file names in a run record (snapshots written before the checkpoint).
pub(crate) fn names(v: &Value) -> Vec<String> {
    v.as_array().map(|a| a.iter().filter_map(|x| x.as_str().map(String::from)).collect()).unwrap_or_default()
}
