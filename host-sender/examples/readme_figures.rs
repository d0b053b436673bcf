//! Writes the CPU model's figures table (`gantry_emulator::cpu_model::figures_table`, from
//! emulator/src/cpu_model_f411.rs) between its markers in the README given as the argument
//! (firmware/README.md). Run by scripts/bench-mcu.sh after it wrote the figures.

use gantry_emulator::cpu_model::{figures_table, with_figures_table, CpuModel};

fn main() -> anyhow::Result<()> {
    let path = std::env::args()
        .nth(1)
        .ok_or_else(|| anyhow::anyhow!("usage: readme_figures README.md"))?;
    let readme = std::fs::read_to_string(&path)?;
    let updated = with_figures_table(&readme, &figures_table(&CpuModel::F411))
        .ok_or_else(|| anyhow::anyhow!("{path}: no bench-mcu markers"))?;
    std::fs::write(&path, updated)?;
    Ok(())
}
