//! fxshade's integration tests, one binary: the CLI end to end, every
//! unit's model against f64 and the paper, and the RTL against the model
//! on Verilator and Icarus Verilog, with Yosys, slang, nextpnr and z3. One
//! binary links once and lets the test harness share both cores among all
//! tests (`cargo test --test suite rtl::` runs one module's tests).

mod common;

mod angles;
mod cluster;
mod config_cli;
mod engine;
mod equiv;
mod explore;
mod formal;
mod integrate;
mod interp;
mod normal_maps;
mod normalize;
mod polar;
mod quantizer;
mod reliability;
mod render;
mod report;
mod rtl;
mod synth;
mod trust;
