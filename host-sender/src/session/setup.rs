//! The board's setup over a connected link: read it (`SetupRequest`, answered by `SetupChunk`s and
//! a `SetupEnd`) and send one (`SetupChunk`s and a `SetupCommit` the board answers by id).

use crate::link::{Client, Transport};
use gantry_proto::setup_commit::SetupRefusal;
use gantry_proto::HostMsg;

/// Sends a setup over an open link; the board validates it, applies it and saves it to flash
/// (idle only).
pub fn push_setup_over<T: Transport>(
    client: &mut Client<T>,
    setup: &gantry_machine::setup::Setup,
) -> anyhow::Result<()> {
    use gantry_machine::setup::SETUP_BLOB_MAX;
    use gantry_proto::messages::SETUP_CHUNK_MAX;
    let mut buf = [0u8; SETUP_BLOB_MAX];
    let blob = setup.to_blob(&mut buf).ok_or_else(|| {
        anyhow::anyhow!("the setup does not fit the board's {SETUP_BLOB_MAX} bytes")
    })?;
    for (i, chunk) in blob.chunks(SETUP_CHUNK_MAX).enumerate() {
        client.send(HostMsg::SetupChunk {
            offset: (i * SETUP_CHUNK_MAX) as u32,
            bytes: heapless::Vec::from_slice(chunk).expect("chunk size"),
        })?;
    }
    let id = client.request_id();
    client.send(HostMsg::SetupCommit {
        id,
        len: blob.len() as u32,
        crc32: gantry_proto::crc::crc32(blob),
    })?;
    match client.await_answer(id, 3000)? {
        Some(0) => Ok(()),
        Some(c) => match SetupRefusal::from_code(c) {
            Some(r) => anyhow::bail!("{}", r.reason()),
            None => anyhow::bail!("the board refused the setup (code {c})"),
        },
        None => anyhow::bail!("the board did not answer the setup within 3 s"),
    }
}

/// [`setup_pull`] over an open link.
pub fn pull_setup_over<T: Transport>(
    client: &mut Client<T>,
) -> anyhow::Result<gantry_machine::setup::Setup> {
    use gantry_proto::BoardMsg;
    let id = client.request_id();
    client.send(HostMsg::SetupRequest { id })?;
    // Other messages (a job's program requests, errors, job ends) are kept for later.
    let mut kept = Vec::new();
    let result = (|| {
        let mut blob = Vec::new();
        let mut damaged = false;
        // The board answers the request before its chunks. Chunks before the answer are a
        // transfer an earlier host asked for and left unacknowledged, which the board sends on
        // to this one (docs/protocol.md §6): the setup as it was then, not now.
        let mut answered = false;
        for _ in 0..3000 {
            client.pump(1)?;
            while let Some(msg) = client.recv() {
                match msg {
                    BoardMsg::Answer { id: got, code } if got == id => {
                        if code != 0 {
                            anyhow::bail!("the board could not send its setup (code {code})");
                        }
                        answered = true;
                    }
                    BoardMsg::SetupChunk { .. } | BoardMsg::SetupEnd { .. } if !answered => {}
                    // Through `gantry serve` another command's request may restart the
                    // board's transfer (offset 0 again): follow the newest one; the length and
                    // CRC check the result.
                    BoardMsg::SetupChunk { offset, bytes } => {
                        if offset == 0 {
                            blob.clear();
                        }
                        if offset as usize == blob.len() {
                            blob.extend_from_slice(&bytes);
                        }
                    }
                    BoardMsg::SetupEnd { len, crc32 } => {
                        if len as usize == blob.len() && gantry_proto::crc::crc32(&blob) == crc32 {
                            return gantry_machine::setup::Setup::from_blob(&blob)
                                .ok_or_else(|| anyhow::anyhow!("the board sent an invalid setup"));
                        }
                        damaged = true;
                        blob.clear();
                    }
                    BoardMsg::Status(_) => {}
                    other => kept.push(other),
                }
            }
        }
        if damaged {
            anyhow::bail!("the board's setup arrived damaged (length or CRC)");
        }
        anyhow::bail!("the board did not send its setup within 3 s (expected its setup chunks)")
    })();
    client.put_back(kept);
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use gantry_emulator::{EmulatedBoard, COUNTS_PER_MS};
    use gantry_machine::setup::Setup;

    /// A host that asked for the setup and went away before acknowledging the board's chunks
    /// leaves that transfer in the board's send window, and the board sends it on to the next
    /// host (it keeps its frames across host sessions). The next host's pull must give the setup
    /// as it is now, not that transfer's: here a setup applied in between (a push from a third
    /// command) would look undone.
    #[test]
    fn a_pull_ignores_the_transfer_an_earlier_host_left_unacknowledged() {
        let old = Setup::default();
        let mut first = Client::connect(EmulatedBoard::new(old.clone()), 2000).unwrap();
        let id = first.request_id();
        first.send(HostMsg::SetupRequest { id }).unwrap();
        first.pump(1).unwrap();
        // The first host is gone: the board sends the whole transfer to nobody.
        let mut board = first.into_transport();
        board.run_for(50 * COUNTS_PER_MS);
        drop(board.take_output());
        let mut new = old.clone();
        new.program.work_offsets[0][0] = 1_000_000;
        assert!(board.board.set_setup(new.clone()));

        let mut second = Client::connect(board, 2000).unwrap();
        let pulled = pull_setup_over(&mut second).unwrap();
        assert_eq!(pulled.program.work_offsets[0][0], 1_000_000);
        assert!(
            pulled == new,
            "the pull gave the setup of the earlier host's transfer"
        );
    }
}
