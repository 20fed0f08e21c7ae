//! save_simulation and load_simulation: files in the workspace, format in `save.rs`.

use crate::log::EventLog;
use base64::Engine;

use crate::command::Command;
use crate::outputs::{Landed, Loaded, Saved};
use crate::files::save_format::{
    chain_blobs, commands_from_readable, disagreeing_fields, readable, saved_event, snapshot_mac,
    world_from_history, SaveFile, SavedHistory, SavedSnapshot, MAX_SAVE_BYTES, SAVE_FORMAT,
    SAVE_FORMAT_VERSION,
};
use crate::files::write::{write_owned, Owned};
use crate::files::Reader;
use crate::sim::{remove_log_files, Registry, Sim};
use crate::sim::timeline::store_err;
use crate::params;
use crate::value::{Args, Refusal};

/// save_simulation's files: saves this server wrote (their `format` field, first in the file).
const SAVED_FILE: Owned = Owned {
    ours: |head| String::from_utf8_lossy(head).contains(&format!("\"{SAVE_FORMAT}\"")),
    what: "a physics-mcp save",
};

impl Sim {
    /// Writes the simulation to a workspace file: readable fields plus the full history chain
    /// and its latest snapshot (MAC'd). Recorded as a read; a refusal changes nothing.
    pub fn save(&mut self, args: &Args, reg: &Registry) -> Result<Saved, Refusal> {
        self.ensure_live()?;
        match self.write_save(args, reg) {
            Ok(out) => self.read("save_simulation", args, |_| Ok(out)),
            Err(why) => Err(self.refuse("save_simulation", args, why)),
        }
    }

    fn write_save(&self, args: &Args, reg: &Registry) -> Result<Saved, Refusal> {
        // The simulation saved is this one: a caller in-process may leave sim_id out.
        let mut args = args.clone();
        args.entry("sim_id").or_insert_with(|| self.id().into());
        let p = params::parse::<params::Save>("save_simulation", &args)?;
        let (user, overwrite) = (p.file_path.0, p.overwrite.is_some_and(|b| b.0));
        let target = reg.sandbox().writable(&user)?;
        let head = self.log.head_seq();
        let chain = self.log.chain_to(head).map_err(store_err)?;
        let latest = self.log.chain_snapshot_seqs(head).map_err(store_err)?.first().copied();
        let stored = match latest {
            Some(seq) => self.log.snapshot_at(seq).map_err(store_err)?.map(|(b, h)| (seq, b, h)),
            None => None,
        };
        // The file carries a snapshot a load can fold on: the latest stored one, or (when that
        // is of an older version, or there is none) the live world's at the head.
        let (snap_seq, bytes, hash) = match stored {
            Some((seq, b, h)) if crate::world::World::foldable_snapshot(&b) => (seq, b, h),
            _ => {
                let b = self.world.snapshot();
                let h = crate::digest::content_hash(&b);
                (head, b, h)
            }
        };
        chain.iter().find(|e| e.seq == snap_seq).ok_or("a snapshot is off the chain")?;
        let events: Vec<_> = chain.iter().map(saved_event).collect();
        let covered: Vec<_> = events.iter().take_while(|e| e.seq <= snap_seq).map(crate::files::save_format::log_event).collect();
        let file = SaveFile {
            format: Some(SAVE_FORMAT.into()),
            format_version: Some(SAVE_FORMAT_VERSION),
            readable: readable(&self.world),
            history: Some(SavedHistory {
                events,
                blobs: chain_blobs(&chain, &self.log),
                snapshot: Some(SavedSnapshot {
                    seq: snap_seq,
                    mac: snapshot_mac(reg.mac_key(), snap_seq, &hash, &covered),
                    hash,
                    bytes: base64::engine::general_purpose::STANDARD.encode(&bytes),
                }),
            }),
        };
        let json = serde_json::to_vec(&file).map_err(|e| e.to_string())?;
        write_owned(reg.sandbox(), &target, &user, &json, &SAVED_FILE, overwrite)?;
        Ok(Saved {
            message: format!("Simulation {} saved to {}", self.id(), reg.sandbox().shown(&target)),
            file_path: reg.sandbox().shown(&target),
            state_hash: self.state_hash.clone(),
        })
    }
}

impl Registry {
    /// Loads a saved file into a new simulation. With a history: from its snapshot when the
    /// MAC is ours, else refolded from its events (every hash checked), then cross-checked
    /// against the readable fields. Without one (the old server's files): objects re-created
    /// at their saved poses and velocities, robots read from the workspace as load_urdf reads
    /// them. A failed load creates nothing.
    pub fn load(
        &self,
        args: &Args,
        new_id: String,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<Loaded, Refusal> {
        let slot = self.reserve()?;
        let p: params::Load = params::parse("load_simulation", args)?;
        let (user, gui, name) = (p.file_path.0, p.gui.is_some_and(|g| g.0), crate::params::lenient::label(p.name)?);
        let mut reader = Reader::with_budget(self.sandbox(), MAX_SAVE_BYTES + crate::files::read::REQUEST_FILE_BYTES);
        let (_, bytes) = reader.read(&user, &format!("file_path {user}"), MAX_SAVE_BYTES)?;
        let file: SaveFile = serde_json::from_slice(&bytes)
            .map_err(|e| format!("The file is not a valid saved simulation: {e}"))?;
        if file.format.as_deref().is_some_and(|f| f != SAVE_FORMAT) {
            return Err(format!("The file is not a valid saved simulation: format {:?}", file.format));
        }
        let sim = match &file.history {
            Some(h) => {
                let (world, chain) = world_from_history(h, self.mac_key(), self.limits(), progress)?;
                if let Some(fields) = disagreeing_fields(&file.readable.with_urdf_path_aliases(), &world) {
                    return Err(format!(
                        "The file's readable fields disagree with its history: {fields} (remove \"history\" to load the readable fields alone)"
                    ));
                }
                let root = Command::LoadSimulation { simulation_id: new_id.clone(), file_path: user.clone(), gui, name: name.clone() };
                let landed = crate::sim::timeline::root_seq_after(&chain).map(|seq| Landed { head_seq: seq, time: world.current_time() });
                let out = Loaded { simulation_id: new_id.clone(), name: name.clone(), file_path: user.clone(), state_hash: world.state_hash(), viewer_url: None, landed };
                let result = serde_json::to_value(&out).map_err(|e| e.to_string())?;
                self.adopt((&chain, &crate::files::save_format::SavedBlobs(&h.blobs), None), &world.with_identity(&new_id, gui), root, "load_simulation", args, &result)?
            }
            None => self.load_readable(&file, &new_id, (gui, name.clone()), args, &mut reader)?,
        };
        // A file without history lands after the commands that re-made it.
        let landed = Some(Landed { head_seq: sim.log().head_seq(), time: sim.world().current_time() });
        let out = Loaded { simulation_id: new_id, name, file_path: user, state_hash: sim.state_hash().to_string(), viewer_url: None, landed };
        slot.fill(sim);
        Ok(out)
    }

    fn load_readable(&self, file: &SaveFile, id: &str, (gui, name): (bool, Option<String>), args: &Args, reader: &mut Reader) -> Result<Sim, Refusal> {
        let path = self.path_for(id);
        // Built under a partial name and renamed when complete: a kill mid-load leaves nothing.
        let partial = crate::log::sqlite::partial_path(&path);
        let mut sim: Option<Sim> = None;
        let emitted = commands_from_readable(&file.readable, id, reader, &mut |tool, cmd| {
            match &mut sim {
                None => {
                    let mut root = cmd;
                    if let Command::CreateSimulation { gui: g, name: n, .. } = &mut root {
                        (*g, *n) = (gui, name.clone());
                    }
                    sim = Some(Sim::create_unpublished(&partial, tool, root, args, self.config().sync)?.0);
                }
                Some(sim) => {
                    // Made from the file, not from a client's call: held to the edge's bounds
                    // here, its model parsed once (the change reuses it).
                    let refused = |why: String| format!("The file's objects cannot be re-created: {why}");
                    let cmd = cmd.ready().map_err(refused)?;
                    sim.change(tool, &Args::new(), Ok(cmd), self.limits(), &mut |_| true).map_err(refused)?;
                }
            }
            Ok(())
        });
        match (emitted, sim) {
            (Ok(()), Some(sim)) => self.publish_sim(sim),
            (Ok(()), None) => Err("The file gave no simulation to create".into()),
            (Err(why), sim) => {
                match sim {
                    Some(sim) => sim.delete(),
                    None => remove_log_files(&partial),
                }
                Err(why)
            }
        }
    }
}
