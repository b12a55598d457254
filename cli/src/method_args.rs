//! `--method` and the method options that `bake` and `render` share.

use anyhow::{anyhow, bail};
use clap::Args;
use transcut::diffusion::SolverKind;
use transcut::gpu::Backend;
use transcut::{Method, TransCutOptions};

/// The subsurface method and its options.
#[derive(Args, Debug, Clone, Default)]
pub struct MethodArgs {
    /// The subsurface method (default: transcut). `--method help` lists every method with one
    /// line each.
    #[arg(long, value_name = "NAME")]
    pub method: Option<String>,
    /// transcut: target number of tetrahedra per object [default: 200000; a scene file's
    /// [bake] tets]
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=50_000_000))]
    pub tets: Option<u64>,
    /// Relative residual ‖b − Mφ‖/‖b‖ at which the solver stops, in (0, 1) [default: 1e-6]
    #[arg(long)]
    pub tolerance: Option<f64>,
    /// transcut: the bake's solver on the CPU: pcg, ssor-pcg (default), cascade, mg-pcg or
    /// sa-pcg (on the GPU the single-level solvers run Jacobi PCG)
    #[arg(long, value_parser = solver_kind)]
    pub solver: Option<SolverKind>,
    /// Where the solve runs: cpu, gpu (an error without a GPU) or auto (a hardware GPU when
    /// there is one, else the CPU). Default: the TRANSCUT_BACKEND environment variable, else
    /// auto.
    #[arg(long)]
    pub backend: Option<Backend>,
}

/// What a scene file's `[bake]` table says about the method (the command line overrides it).
#[derive(Debug, Clone, Default)]
pub struct MethodDefaults {
    pub method: Option<String>,
    pub tets: Option<u64>,
    pub tolerance: Option<f64>,
    pub solver: Option<String>,
}

/// Parses a solver name ([`SolverKind::from_name`]).
///
/// # Errors
/// The valid names.
pub fn solver_kind(name: &str) -> Result<SolverKind, String> {
    SolverKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = SolverKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown solver '{name}' (the solvers are: {})", names.join(", "))
    })
}

/// The text of `--method help`: every method, one line each.
#[must_use]
pub fn method_help() -> String {
    let methods = Method::all();
    let width = methods.iter().map(|m| m.name().len()).max().unwrap_or(0);
    let mut out = String::from("methods (--method NAME):\n");
    for m in &methods {
        out.push_str(&format!("  {:width$}  {}\n", m.name(), m.description()));
    }
    out
}

impl MethodArgs {
    /// Whether `--method help` was given.
    #[must_use]
    pub fn wants_help(&self) -> bool {
        self.method.as_deref().is_some_and(|m| m.trim().eq_ignore_ascii_case("help"))
    }

    /// The method these arguments choose, over `defaults` (a scene file's): its name, then its
    /// options.
    ///
    /// # Errors
    /// An unknown method or solver name (listing the valid ones).
    pub fn method(&self, defaults: &MethodDefaults) -> anyhow::Result<Method> {
        let name = self.method.as_deref().or(defaults.method.as_deref()).unwrap_or("transcut");
        let method = Method::from_name(name).ok_or_else(|| anyhow!("{}", Method::unknown(name)))?;
        Ok(match method {
            Method::TransCut(d) => {
                let solver = match (&self.solver, &defaults.solver) {
                    (Some(k), _) => *k,
                    (None, Some(name)) => solver_kind(name).map_err(|e| anyhow!("[bake] solver: {e}"))?,
                    (None, None) => d.solver,
                };
                let tets = self.tets.or(defaults.tets).map_or(Ok(d.tets), usize::try_from)?;
                if tets == 0 {
                    bail!("tets must be at least 1");
                }
                Method::TransCut(TransCutOptions {
                    tets,
                    tolerance: self.tolerance.or(defaults.tolerance).unwrap_or(d.tolerance),
                    solver,
                    backend: self.backend,
                    ..d
                })
            }
            _ => bail!("{}", Method::unknown(name)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_choose_the_method_and_the_command_line_overrides_the_file() {
        let file = MethodDefaults {
            method: Some("transcut".into()),
            tets: Some(5000),
            tolerance: Some(1e-4),
            solver: Some("mg-pcg".into()),
        };
        let Method::TransCut(o) = MethodArgs::default().method(&file).unwrap() else { panic!() };
        assert_eq!((o.tets, o.tolerance, o.solver), (5000, 1e-4, SolverKind::MultigridPcg));
        let args = MethodArgs { tets: Some(7), solver: Some(SolverKind::Pcg), ..MethodArgs::default() };
        let Method::TransCut(o) = args.method(&file).unwrap() else { panic!() };
        assert_eq!((o.tets, o.solver), (7, SolverKind::Pcg));
        assert_eq!(MethodArgs::default().method(&MethodDefaults::default()).unwrap(), Method::default());
    }

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let args = MethodArgs { method: Some("nonsense".into()), ..MethodArgs::default() };
        let e = args.method(&MethodDefaults::default()).unwrap_err().to_string();
        assert!(e.contains("nonsense") && e.contains("transcut"), "{e}");
        let file = MethodDefaults { solver: Some("gauss".into()), ..MethodDefaults::default() };
        let e = MethodArgs::default().method(&file).unwrap_err().to_string();
        assert!(e.contains("gauss") && e.contains("ssor-pcg"), "{e}");
        assert!(method_help().contains("transcut"));
        assert!(MethodArgs { method: Some("Help".into()), ..MethodArgs::default() }.wants_help());
    }
}
