//! The runtime's integration tests in one binary (one link of wgpu and naga
//! instead of one per file), sharing one device ([`common::gpu`]).

mod atomic_output;
mod bad_input;
mod bench_refs;
mod bench_smoke;
mod bricks;
mod cli;
mod common;
mod curvature;
mod dvr;
mod frames;
mod gpu_bench;
mod gpu_verify;
mod gpu_verify_4d;
mod hessian;
mod hessian_refs;
mod hit;
mod host_depth;
mod mattausch_references;
mod paged;
mod paged_dvr;
mod params;
mod perm;
mod prefilter;
mod pt;
mod render;
mod render_4d;
mod targets_run;
mod web;
mod zarr;
mod zarr_http;
mod zarr_lattice;
