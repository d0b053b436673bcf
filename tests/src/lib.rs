//! Support code for Gantry's whole-system tests.
