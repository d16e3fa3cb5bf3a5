//! The backend that advances a solver: the CPU reference, or the GPU with the CPU solver as a
//! mirror that receives the GPU state after every advance (for outputs and measurements).

use crate::fluid::{FluidSolver, Instability};
use crate::gpu::{GpuContext, GpuError, GpuFluid};
use serde::Serialize;

/// Which solver backend runs the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    Cpu,
    Gpu,
    /// The GPU when the adapter is a real (discrete or integrated) GPU, else the CPU: a software
    /// rasteriser such as lavapipe is slower than the CPU backend.
    #[default]
    Auto,
}

/// The GPU context a run should use for `backend` (None: run on the CPU), and a line saying
/// what was chosen. `Auto` takes the GPU only when the adapter is a hardware GPU; `Gpu` fails
/// when there is no adapter.
pub fn pick_gpu(backend: Backend) -> Result<(Option<GpuContext>, String), GpuError> {
    let threads = rayon::current_num_threads();
    if backend != Backend::Cpu {
        match GpuContext::new() {
            Ok(ctx) => {
                let real = matches!(ctx.info.device_type, wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu);
                if backend == Backend::Gpu || real {
                    let name = format!("gpu: {}", ctx.describe());
                    return Ok((Some(ctx), name));
                }
                return Ok((None, format!("cpu ({threads} threads; adapter {} is not a hardware GPU)", ctx.describe())));
            }
            Err(e) if backend == Backend::Gpu => return Err(e),
            Err(_) => {}
        }
    }
    Ok((None, format!("cpu ({threads} threads)")))
}

/// The solver a run advances: the CPU reference, or the GPU with a CPU mirror that receives
/// the GPU state whenever outputs are written.
pub enum Engine {
    Cpu,
    Gpu(Box<GpuFluid>),
}

impl Engine {
    /// Picks the backend and uploads `s` to the GPU when it is chosen; also says what was chosen.
    pub fn new(backend: Backend, s: &FluidSolver) -> Result<(Engine, String), GpuError> {
        Ok(match pick_gpu(backend)? {
            (Some(ctx), name) => (Engine::Gpu(Box::new(GpuFluid::from_solver(&ctx, s)?)), name),
            (None, name) => (Engine::Cpu, name),
        })
    }

    /// Advances `n` steps; on the GPU, copies the state back into `s` afterwards.
    pub fn advance(&mut self, s: &mut FluidSolver, n: u64) -> Result<(), Instability> {
        match self {
            Engine::Cpu => s.run(n),
            Engine::Gpu(g) => {
                g.run(n);
                if let Some((node, code)) = g.instability() {
                    // `s` keeps the last state copied back (finite).
                    let quantity = ["", "density", "velocity", "temperature"][code as usize];
                    return Err(Instability {
                        step: g.step_count,
                        time: g.step_count as f64 * s.params.dt,
                        node: s.layout.grid.coords(node),
                        quantity,
                        value: f64::NAN,
                        reason: format!("{quantity} left its admissible range on the GPU within the last {n} steps"),
                    });
                }
                g.download_into(s);
                Ok(())
            }
        }
    }
}
