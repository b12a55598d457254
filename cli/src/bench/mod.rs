//! `transcut bench`: benchmarks with JSON output. Times are medians of several runs measured in
//! one process, so ratios between entries are meaningful on a noisy machine. One file per
//! suite; [`stats`] holds what they share and [`fig7`] TransCut's Fig. 7, which `multires` and
//! `edit` both measure.

mod args;
mod bake;
mod dipole;
mod edit;
mod fig7;
mod inverse;
mod inverse_quality;
mod mesh;
mod multires;
mod polygrid;
mod prt;
mod radiosity;
mod radiosity_coupled;
mod solve;
mod sphere;
mod stats;

pub use args::{BenchArgs, Suite};

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    match args.suite {
        Suite::Mesh => mesh::run(args),
        Suite::Bake => bake::run(args),
        Suite::Solve => solve::run(args),
        Suite::Multires => multires::run(args),
        Suite::Edit => edit::run(args),
        Suite::Dipole => dipole::run(args),
        Suite::Radiosity => radiosity::run(args),
        Suite::Prt => prt::run(args),
        Suite::Polygrid => polygrid::run(args),
        Suite::Inverse => inverse::run(args),
        Suite::Sphere => sphere::run(args),
    }
}
