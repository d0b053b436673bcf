//! The emulated board (`gantry-emulator`) as a [`Transport`]: bytes go straight into its port,
//! and waiting runs its virtual time, so an in-process session runs the board's own code at the
//! speed of the host.

use crate::link::Transport;
use gantry_emulator::EmulatedBoard;

/// The emulated board as a transport: waiting runs it on virtual time.
impl Transport for EmulatedBoard {
    fn write(&mut self, bytes: &[u8]) -> anyhow::Result<()> {
        self.receive(bytes);
        Ok(())
    }

    fn read(&mut self, into: &mut Vec<u8>) -> anyhow::Result<()> {
        into.extend(self.take_output());
        Ok(())
    }

    fn wait(&mut self, ms: u32) {
        self.run_for(ms as u64 * gantry_emulator::COUNTS_PER_MS);
    }

    fn now_ms(&self) -> u32 {
        EmulatedBoard::now_ms(self)
    }

    fn underruns(&self) -> Option<u64> {
        Some(self.starved.gaps)
    }
}
