//! `--method` and the method options that `bake`, `render` and `animate` share.
//!
//! Every option belongs to one method (its help says which); an option of one method given
//! with another is refused, naming both, rather than silently ignored.

use anyhow::{anyhow, bail};
use clap::{Args, ValueEnum};
use transcut::diffusion::SolverKind;
use transcut::gpu::Backend;
use transcut::hierarchy::{DipoleOptions, EvalMode, Oracle, Receivers};
use transcut::optics::EdgeRule;
use transcut::{Method, TransCutOptions};

/// The names of the methods whose options are here ([`Method::NAMES`]).
const TRANSCUT: &str = "transcut";
const DIPOLE: &str = transcut::methods::hierarchical_dipole::NAME;

/// θ of `--oracle opening-angle` without `--theta`: the core's default ([`Oracle::default`]).
const DEFAULT_THETA: f64 = 0.4;

/// The mode without `--mode` (nor a command's default): the core's ([`EvalMode::default`]).
const DEFAULT_MODE: ModeName = ModeName::OnTheFly;

/// The paper oracle's ε₁ and ε₂ when not given: the paper publishes none; pbrt-v2 and Blender
/// 2.4x default to 0.05 (design/hierarchical-dipole.md §1.6).
const PAPER_EPS: f64 = 0.05;

/// The hierarchical dipole's refinement oracle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OracleName {
    /// Link two clusters when their radii sum below θ × their distance (--theta).
    OpeningAngle,
    /// Mertens et al. 2003's solid-angle test (--eps1, --eps2), for reproduction: on sun-lit
    /// spheres of 5k-20k triangles 0.5-5.5% RMS against the O(n²) sum, opening-angle θ 0.4's
    /// 0.04% (`transcut bench dipole`).
    Paper,
}

/// The edge rule of the near field's analytic triangle form factor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RuleName {
    /// 3-point Gauss–Legendre per edge segment: within 1.2e-4 of brute-force cubature.
    Gl3,
    /// The paper's midpoint rule (eq. 17, L/r₀ < 2/5): 3–17% off away from the receiver.
    Paper,
}

/// Where the hierarchical dipole evaluates the radiance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReceiverName {
    /// At every vertex, along its area-weighted normal.
    Vertices,
    /// At every triangle's centroid (the paper's), averaged onto the vertices by area.
    Faces,
}

/// When the hierarchical dipole makes its links.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModeName {
    /// Traverse the cluster trees afresh at every update, storing no links (least memory).
    OnTheFly,
    /// Keep the links and their form factors: a relight only gathers; a deformation relinks
    /// everything.
    Render,
    /// Keep the links; after a deformation relink only what moved (--budget caps the form
    /// factors per update).
    Incremental,
}

/// The subsurface method and its options.
#[derive(Args, Debug, Clone, Default)]
pub struct MethodArgs {
    /// The subsurface method: transcut or hierarchical-dipole (the default is the command's:
    /// transcut for bake and render, hierarchical-dipole for animate). `--method help` lists
    /// every method with one line each.
    #[arg(long, value_name = "NAME")]
    pub method: Option<String>,
    /// transcut: target number of tetrahedra per object [default: 200000; a scene file's
    /// [bake] tets]
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=50_000_000), help_heading = "TransCut options")]
    pub tets: Option<u64>,
    /// transcut: relative residual ‖b − Mφ‖/‖b‖ at which the solver stops, in (0, 1)
    /// [default: 1e-6]
    #[arg(long, help_heading = "TransCut options")]
    pub tolerance: Option<f64>,
    /// transcut: the bake's solver on the CPU: pcg, ssor-pcg (default), cascade, mg-pcg or
    /// sa-pcg (on the GPU the single-level solvers run Jacobi PCG)
    #[arg(long, value_parser = solver_kind, help_heading = "TransCut options")]
    pub solver: Option<SolverKind>,
    /// transcut: where the solve runs: cpu, gpu (an error without a GPU) or auto (a hardware
    /// GPU when there is one, else the CPU). Default: the TRANSCUT_BACKEND environment
    /// variable, else auto.
    #[arg(long, help_heading = "TransCut options")]
    pub backend: Option<Backend>,
    /// hierarchical-dipole: the opening-angle oracle's θ in (0, 1]: a far link joins two
    /// clusters whose bounding radii sum below θ × their distance. Smaller is more accurate and
    /// slower: 0.6 fast (0.09% RMS against the O(n²) sum on a sun-lit sphere), 0.4 the default
    /// (0.04%), 0.3 accurate (0.01%).
    #[arg(long, value_name = "F", help_heading = "Hierarchical-dipole options")]
    pub theta: Option<f64>,
    /// hierarchical-dipole: the refinement oracle that decides where links are made
    /// [default: opening-angle]
    #[arg(long, value_enum, value_name = "ORACLE", help_heading = "Hierarchical-dipole options")]
    pub oracle: Option<OracleName>,
    /// hierarchical-dipole, --oracle paper: ε₁, how far (in solid angle) a receiver cluster's
    /// children may see an emitter differently from the cluster before it is opened
    /// [default: 0.05]
    #[arg(long, value_name = "F", help_heading = "Hierarchical-dipole options")]
    pub eps1: Option<f64>,
    /// hierarchical-dipole, --oracle paper: ε₂, the largest solid angle A/d² under which an
    /// emitter cluster is linked whole [default: 0.05]
    #[arg(long, value_name = "F", help_heading = "Hierarchical-dipole options")]
    pub eps2: Option<f64>,
    /// hierarchical-dipole: the edge rule of the near field's analytic triangle form factor
    /// [default: gl3]
    #[arg(long, value_enum, value_name = "RULE", help_heading = "Hierarchical-dipole options")]
    pub rule: Option<RuleName>,
    /// hierarchical-dipole: where the radiance is evaluated [default: vertices]
    #[arg(long, value_enum, value_name = "AT", help_heading = "Hierarchical-dipole options")]
    pub receivers: Option<ReceiverName>,
    /// hierarchical-dipole: when links are made [default: on-the-fly; incremental for animate]
    #[arg(long, value_enum, value_name = "MODE", help_heading = "Hierarchical-dipole options")]
    pub mode: Option<ModeName>,
    /// hierarchical-dipole, --mode incremental: relink at most about N links per update,
    /// oldest first, keeping the others as they were (the error decays once motion stops)
    /// [default: no cap]
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..), help_heading = "Hierarchical-dipole options")]
    pub budget: Option<u64>,
}

/// The defaults under the command line: what a scene file's `[bake]` table says, or a
/// command's own (animate's method and mode).
#[derive(Debug, Clone, Default)]
pub struct MethodDefaults {
    /// Whether these are a scene file's (whose options are checked against its method).
    pub from_file: bool,
    pub method: Option<String>,
    pub tets: Option<u64>,
    pub tolerance: Option<f64>,
    pub solver: Option<String>,
    /// The hierarchical dipole's mode when `--mode` is not given.
    pub mode: Option<ModeName>,
    /// The hierarchical dipole's opening angle when `--theta` is not given (a scene file's).
    pub theta: Option<f64>,
}

impl MethodDefaults {
    /// The defaults of a scene file's `[bake]` table: its method, TransCut's `tets`,
    /// `tolerance` and `solver`, the dipole's `theta` and `mode`.
    ///
    /// # Errors
    /// An unknown mode name, listing the valid ones.
    pub fn from_bake_table(
        method: Option<String>,
        tets: Option<u64>,
        tolerance: Option<f64>,
        solver: Option<String>,
        theta: Option<f64>,
        mode: Option<&str>,
    ) -> anyhow::Result<Self> {
        let mode = mode
            .map(|m| {
                ModeName::from_str(m, true)
                    .map_err(|_| anyhow!("[bake] mode: unknown mode '{m}' (the modes are: on-the-fly, render, incremental)"))
            })
            .transpose()?;
        Ok(Self { method, tets, tolerance, solver, mode, theta, from_file: true })
    }
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

/// The first of `options` (given?, name, method) that was given and is not of `method`.
fn foreign(options: &[(bool, &'static str, &'static str)], method: &str) -> Option<(&'static str, &'static str)> {
    options.iter().find(|(given, _, owner)| *given && *owner != method).map(|&(_, name, owner)| (name, owner))
}

impl MethodArgs {
    /// Whether `--method help` was given.
    #[must_use]
    pub fn wants_help(&self) -> bool {
        self.method.as_deref().is_some_and(|m| m.trim().eq_ignore_ascii_case("help"))
    }

    /// Every method option: whether it was given, its flag and its method.
    fn options(&self) -> [(bool, &'static str, &'static str); 12] {
        [
            (self.tets.is_some(), "--tets", TRANSCUT),
            (self.tolerance.is_some(), "--tolerance", TRANSCUT),
            (self.solver.is_some(), "--solver", TRANSCUT),
            (self.backend.is_some(), "--backend", TRANSCUT),
            (self.theta.is_some(), "--theta", DIPOLE),
            (self.oracle.is_some(), "--oracle", DIPOLE),
            (self.eps1.is_some(), "--eps1", DIPOLE),
            (self.eps2.is_some(), "--eps2", DIPOLE),
            (self.rule.is_some(), "--rule", DIPOLE),
            (self.receivers.is_some(), "--receivers", DIPOLE),
            (self.mode.is_some(), "--mode", DIPOLE),
            (self.budget.is_some(), "--budget", DIPOLE),
        ]
    }

    /// The method these arguments choose, over `defaults` (a scene file's or the command's):
    /// its name, then its options.
    ///
    /// # Errors
    /// An unknown method or solver name (listing the valid ones); an option of another method
    /// than the one chosen (naming both); options that contradict each other; options out of
    /// range ([`Method::validate`]).
    pub fn method(&self, defaults: &MethodDefaults) -> anyhow::Result<Method> {
        let name = self.method.as_deref().or(defaults.method.as_deref()).unwrap_or(TRANSCUT);
        let method = Method::from_name(name).ok_or_else(|| anyhow!("{}", Method::unknown(name)))?;
        if let Some((option, owner)) = foreign(&self.options(), method.name()) {
            bail!("{option} is an option of the {owner} method, not of {} (the method chosen)", method.name());
        }
        // A scene file's TransCut options, when the file itself chose another method: written
        // for nothing. (When the command line chose the method, they were for the file's.)
        if self.method.is_none() && defaults.from_file {
            let file = [
                (defaults.tets.is_some(), "tets", TRANSCUT),
                (defaults.tolerance.is_some(), "tolerance", TRANSCUT),
                (defaults.solver.is_some(), "solver", TRANSCUT),
                (defaults.theta.is_some(), "theta", DIPOLE),
                (defaults.mode.is_some(), "mode", DIPOLE),
            ];
            if let Some((option, owner)) = foreign(&file, method.name()) {
                bail!("[bake] {option} is an option of the {owner} method, not of {} (the file's method)", method.name());
            }
        }
        let method = match method {
            Method::TransCut(d) => {
                let solver = match (&self.solver, &defaults.solver) {
                    (Some(k), _) => *k,
                    (None, Some(name)) => solver_kind(name).map_err(|e| anyhow!("[bake] solver: {e}"))?,
                    (None, None) => d.solver,
                };
                let tets = self.tets.or(defaults.tets).map_or(Ok(d.tets), usize::try_from)?;
                Method::TransCut(TransCutOptions {
                    tets,
                    tolerance: self.tolerance.or(defaults.tolerance).unwrap_or(d.tolerance),
                    solver,
                    backend: self.backend,
                    ..d
                })
            }
            Method::HierarchicalDipole(d) => Method::HierarchicalDipole(self.dipole(d, defaults)?),
            _ => bail!("{}", Method::unknown(name)),
        };
        method.validate().map_err(|e| anyhow!(e))?;
        Ok(method)
    }

    /// The hierarchical dipole's options over `d`, its defaults.
    fn dipole(&self, d: DipoleOptions, defaults: &MethodDefaults) -> anyhow::Result<DipoleOptions> {
        // A scene file's theta stands in for --theta unless the command line chose the paper
        // oracle, which has none.
        let theta = self.theta.or(defaults.theta.filter(|_| self.oracle != Some(OracleName::Paper)));
        let oracle = match (self.oracle, theta) {
            (None, None) if self.eps1.is_none() && self.eps2.is_none() => d.oracle,
            (None | Some(OracleName::OpeningAngle), theta) => {
                if let Some(flag) = [(self.eps1, "--eps1"), (self.eps2, "--eps2")].iter().find_map(|(v, f)| v.map(|_| f)) {
                    bail!(
                        "{flag} is a threshold of the paper oracle: give --oracle paper (the opening-angle oracle takes --theta)"
                    );
                }
                Oracle::OpeningAngle { theta: theta.unwrap_or(DEFAULT_THETA) }
            }
            (Some(OracleName::Paper), None) => {
                Oracle::Paper { eps1: self.eps1.unwrap_or(PAPER_EPS), eps2: self.eps2.unwrap_or(PAPER_EPS) }
            }
            (Some(OracleName::Paper), Some(_)) => {
                bail!("--theta is the opening-angle oracle's: --oracle paper takes --eps1 and --eps2")
            }
        };
        let mode = match (self.mode.or(defaults.mode).unwrap_or(DEFAULT_MODE), self.budget) {
            (ModeName::Incremental, budget) => EvalMode::Incremental { budget: budget.map(usize::try_from).transpose()? },
            (name, Some(_)) => {
                let name = name.to_possible_value().map(|v| v.get_name().to_owned()).unwrap_or_default();
                bail!("--budget caps the links an incremental update makes: it needs --mode incremental (the mode is {name})")
            }
            (ModeName::OnTheFly, None) => EvalMode::OnTheFly,
            (ModeName::Render, None) => EvalMode::Render,
        };
        Ok(DipoleOptions {
            oracle,
            rule: match self.rule {
                None => d.rule,
                Some(RuleName::Gl3) => EdgeRule::default(),
                Some(RuleName::Paper) => EdgeRule::PAPER,
            },
            receivers: match self.receivers {
                None => d.receivers,
                Some(ReceiverName::Vertices) => Receivers::Vertices,
                Some(ReceiverName::Faces) => Receivers::FaceCentroids,
            },
            mode,
            ..d
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dipole(args: MethodArgs) -> anyhow::Result<DipoleOptions> {
        match (MethodArgs { method: Some(DIPOLE.into()), ..args }).method(&MethodDefaults::default())? {
            Method::HierarchicalDipole(o) => Ok(o),
            other => panic!("{other:?}"),
        }
    }

    fn error(args: MethodArgs, defaults: &MethodDefaults) -> String {
        args.method(defaults).unwrap_err().to_string()
    }

    #[test]
    fn the_method_names_are_the_cores() {
        assert!(Method::NAMES.contains(&TRANSCUT) && Method::NAMES.contains(&DIPOLE));
        assert_eq!(Method::default().name(), TRANSCUT);
        assert_eq!(Oracle::default(), Oracle::OpeningAngle { theta: DEFAULT_THETA });
        assert_eq!(EvalMode::default(), EvalMode::OnTheFly);
        assert_eq!(DEFAULT_MODE, ModeName::OnTheFly);
    }

    #[test]
    fn names_choose_the_method_and_the_command_line_overrides_the_file() {
        let file =
            MethodDefaults::from_bake_table(Some("transcut".into()), Some(5000), Some(1e-4), Some("mg-pcg".into()), None, None)
                .unwrap();
        let Method::TransCut(o) = MethodArgs::default().method(&file).unwrap() else { panic!() };
        assert_eq!((o.tets, o.tolerance, o.solver), (5000, 1e-4, SolverKind::MultigridPcg));
        let args = MethodArgs { tets: Some(7), solver: Some(SolverKind::Pcg), ..MethodArgs::default() };
        let Method::TransCut(o) = args.method(&file).unwrap() else { panic!() };
        assert_eq!((o.tets, o.solver), (7, SolverKind::Pcg));
        assert_eq!(MethodArgs::default().method(&MethodDefaults::default()).unwrap(), Method::default());
        // The command line's method over the file's: the file's TransCut options are not its.
        let args = MethodArgs { method: Some("hierarchical-dipole".into()), ..MethodArgs::default() };
        assert_eq!(args.method(&file).unwrap(), Method::HierarchicalDipole(DipoleOptions::default()));
    }

    #[test]
    fn a_scene_files_dipole_options_apply_to_the_dipole_only() {
        let table = |method: Option<&str>, theta, mode| {
            MethodDefaults::from_bake_table(method.map(Into::into), None, None, None, theta, mode)
        };
        let file = table(Some(DIPOLE), Some(0.3), Some("render")).unwrap();
        let Method::HierarchicalDipole(o) = MethodArgs::default().method(&file).unwrap() else { panic!() };
        assert_eq!((o.oracle, o.mode), (Oracle::OpeningAngle { theta: 0.3 }, EvalMode::Render));
        // The command line overrides the file; its paper oracle has no theta.
        let args = MethodArgs { theta: Some(0.6), mode: Some(ModeName::OnTheFly), ..MethodArgs::default() };
        let Method::HierarchicalDipole(o) = args.method(&file).unwrap() else { panic!() };
        assert_eq!((o.oracle, o.mode), (Oracle::OpeningAngle { theta: 0.6 }, EvalMode::OnTheFly));
        let paper = MethodArgs { oracle: Some(OracleName::Paper), ..MethodArgs::default() };
        let Method::HierarchicalDipole(o) = paper.method(&file).unwrap() else { panic!() };
        assert_eq!(o.oracle, Oracle::Paper { eps1: PAPER_EPS, eps2: PAPER_EPS });
        // A file of TransCut (named, or by default) with the dipole's options is refused by name.
        for method in [None, Some(TRANSCUT)] {
            let e = error(MethodArgs::default(), &table(method, Some(0.3), None).unwrap());
            assert!(e.contains("[bake] theta") && e.contains("hierarchical-dipole"), "{e}");
        }
        let e = table(Some(DIPOLE), None, Some("sometimes")).unwrap_err().to_string();
        assert!(e.contains("'sometimes'") && e.contains("incremental"), "{e}");
        // Out of range through the core's check.
        let e = error(MethodArgs::default(), &table(Some(DIPOLE), Some(1.5), None).unwrap());
        assert!(e.contains("theta"), "{e}");
    }

    #[test]
    fn unknown_names_list_the_valid_ones() {
        let args = MethodArgs { method: Some("nonsense".into()), ..MethodArgs::default() };
        let e = error(args, &MethodDefaults::default());
        assert!(e.contains("nonsense") && e.contains("transcut") && e.contains("hierarchical-dipole"), "{e}");
        let file = MethodDefaults { solver: Some("gauss".into()), ..MethodDefaults::default() };
        let e = error(MethodArgs::default(), &file);
        assert!(e.contains("gauss") && e.contains("ssor-pcg"), "{e}");
        assert!(method_help().contains("transcut") && method_help().contains("hierarchical-dipole"));
        assert!(MethodArgs { method: Some("Help".into()), ..MethodArgs::default() }.wants_help());
    }

    #[test]
    fn dipole_options_map_onto_the_cores() {
        assert_eq!(dipole(MethodArgs::default()).unwrap(), DipoleOptions::default());
        let o = dipole(MethodArgs {
            theta: Some(0.3),
            rule: Some(RuleName::Paper),
            receivers: Some(ReceiverName::Faces),
            mode: Some(ModeName::Incremental),
            budget: Some(5000),
            ..MethodArgs::default()
        })
        .unwrap();
        assert_eq!(o.oracle, Oracle::OpeningAngle { theta: 0.3 });
        assert_eq!(o.rule, EdgeRule::PAPER);
        assert_eq!(o.receivers, Receivers::FaceCentroids);
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(5000) });
        let o = dipole(MethodArgs { oracle: Some(OracleName::Paper), eps2: Some(0.02), ..MethodArgs::default() }).unwrap();
        assert_eq!(o.oracle, Oracle::Paper { eps1: 0.05, eps2: 0.02 });
        for (mode, want) in [(ModeName::OnTheFly, EvalMode::OnTheFly), (ModeName::Render, EvalMode::Render)] {
            assert_eq!(dipole(MethodArgs { mode: Some(mode), ..MethodArgs::default() }).unwrap().mode, want);
        }
        assert_eq!(dipole(MethodArgs { rule: Some(RuleName::Gl3), ..MethodArgs::default() }).unwrap().rule, EdgeRule::default());
        // A command's default mode (animate's), and --budget under it.
        let animate =
            MethodDefaults { method: Some(DIPOLE.into()), mode: Some(ModeName::Incremental), ..MethodDefaults::default() };
        let Method::HierarchicalDipole(o) = MethodArgs { budget: Some(10), ..MethodArgs::default() }.method(&animate).unwrap()
        else {
            panic!()
        };
        assert_eq!(o.mode, EvalMode::Incremental { budget: Some(10) });
    }

    #[test]
    fn options_of_another_method_are_refused_by_name() {
        let none = MethodDefaults::default();
        let e = error(MethodArgs { theta: Some(0.4), ..MethodArgs::default() }, &none);
        assert!(e.contains("--theta") && e.contains("hierarchical-dipole") && e.contains("not of transcut"), "{e}");
        let args = MethodArgs { method: Some(DIPOLE.into()), tets: Some(1000), ..MethodArgs::default() };
        let e = error(args, &none);
        assert!(e.contains("--tets") && e.contains("of the transcut method, not of hierarchical-dipole"), "{e}");
        let args = MethodArgs { method: Some("transcut".into()), mode: Some(ModeName::Render), ..MethodArgs::default() };
        assert!(error(args, &none).contains("--mode"));
        // A file that chose the dipole and gave TransCut's options.
        let file = MethodDefaults::from_bake_table(Some(DIPOLE.into()), None, None, Some("pcg".into()), None, None).unwrap();
        let e = error(MethodArgs::default(), &file);
        assert!(e.contains("[bake] solver") && e.contains("transcut"), "{e}");
    }

    #[test]
    fn contradicting_or_out_of_range_dipole_options_are_refused() {
        let cases: [(MethodArgs, &[&str]); 6] = [
            (MethodArgs { oracle: Some(OracleName::Paper), theta: Some(0.4), ..MethodArgs::default() }, &["--theta", "--eps1"]),
            (MethodArgs { eps1: Some(0.1), ..MethodArgs::default() }, &["--eps1", "--oracle paper"]),
            (MethodArgs { budget: Some(10), ..MethodArgs::default() }, &["--budget", "--mode incremental", "on-the-fly"]),
            (MethodArgs { budget: Some(10), mode: Some(ModeName::Render), ..MethodArgs::default() }, &["render"]),
            (MethodArgs { theta: Some(1.5), ..MethodArgs::default() }, &["hierarchical-dipole", "theta", "(0, 1]"]),
            (MethodArgs { oracle: Some(OracleName::Paper), eps1: Some(-1.0), ..MethodArgs::default() }, &["eps1", "> 0"]),
        ];
        for (args, words) in cases {
            let e = format!("{:#}", dipole(args.clone()).unwrap_err());
            assert!(words.iter().all(|w| e.contains(w)), "{args:?}: {e}");
        }
    }
}
