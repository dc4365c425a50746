//! End-to-end tests of the reference path tracer. Every tolerance is a multiple of a measured
//! standard error plus, where an expected value comes from quadrature or geometry, that
//! value's own derived error bound.

mod brdf;
mod camera;
mod common;
mod convergence;
mod determinism;
mod direct;
mod emitters;
mod furnace;
mod irradiance;
mod mis;
