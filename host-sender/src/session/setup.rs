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
    client.send(HostMsg::SetupRequest)?;
    // Other messages (a job's program requests, errors, job ends) are kept for later.
    let mut kept = Vec::new();
    let result = (|| {
        let mut blob = Vec::new();
        let mut damaged = false;
        for _ in 0..3000 {
            client.pump(1)?;
            while let Some(msg) = client.recv() {
                match msg {
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
