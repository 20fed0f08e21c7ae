//! The `physics-mcp` command line: `serve` (HTTP), `stdio`, `replay`, `report`, `history`, `diff`,
//! `call`.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::{Parser, Subcommand};
use physics_mcp::cli::LimitArgs;
use physics_mcp::mcp::transport::{serve_http, serve_stdio, HttpOptions};
use physics_mcp::sim::{Config, Registry};
use physics_mcp::log::sqlite::SyncMode;

/// An MCP server for deterministic, replayable rigid-body physics (rapier3d).
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
    /// Threads each simulation steps on (rapier's parallel solver). Results and hashes are the
    /// same for any count; more threads help large scenes when cores are free.
    #[arg(long, global = true, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..=256))]
    threads: u16,
}

/// Where simulations live and how they are limited (shared by serve and stdio).
#[derive(clap::Args)]
struct Common {
    /// Directory holding one SQLite log per simulation (exclusively locked while running).
    /// Default: ./physics-mcp-data, or $XDG_DATA_HOME/physics-mcp/data (~/.local/share/…) when
    /// the working directory is /, the home directory or not writable.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Directory that URDF, save and load paths are confined to. Default:
    /// ./physics-mcp-workspace, or beside the data directory's default as for --data.
    #[arg(long)]
    workspace: Option<PathBuf>,
    /// Durability: `normal` survives a killed process; `full` also fsyncs for power loss.
    #[arg(long, value_enum, default_value_t = SyncMode::Normal)]
    sync: SyncMode,
    #[command(flatten)]
    limits: LimitArgs,
}

/// Joining a NATS JetStream cluster (docs/cluster.md); absent, the log is embedded SQLite.
#[derive(clap::Args)]
struct ClusterArgs {
    /// Keep the log of record in this NATS JetStream cluster: nats://HOST:PORT[,…]. --data is
    /// then only this node's cache, and --workspace must be a directory every node shares.
    #[arg(long, value_name = "URLS")]
    cluster: Option<String>,
    /// This node's name in the cluster (unique per live node; default: host name and pid).
    #[arg(long, requires = "cluster")]
    node: Option<String>,
    /// Prefix of the streams, buckets and subjects kept in NATS (deployments sharing one NATS
    /// cluster use different ones).
    #[arg(long, default_value = "pmcp")]
    cluster_namespace: String,
    /// Streams the simulations are spread over (the first node's value holds cluster-wide).
    #[arg(long, default_value_t = 4)]
    cluster_streams: u32,
    /// Replicas of every stream and bucket (3 survives the loss of one NATS server).
    #[arg(long, default_value_t = 3)]
    cluster_replicas: usize,
    /// A lease's life in milliseconds unless renewed (the first node's value holds cluster-wide).
    #[arg(long, default_value_t = 5000)]
    lease_ms: u64,
}

impl ClusterArgs {
    /// Connects when --cluster is given.
    fn connect(&self) -> anyhow::Result<Option<Arc<physics_mcp::cluster::Cluster>>> {
        let Some(urls) = &self.cluster else { return Ok(None) };
        let node = self.node.clone().unwrap_or_else(default_node_name);
        let mut config = physics_mcp::cluster::ClusterConfig::new(urls, &node);
        config.namespace = self.cluster_namespace.clone();
        config.streams = self.cluster_streams;
        config.replicas = self.cluster_replicas;
        config.lease = std::time::Duration::from_millis(self.lease_ms);
        physics_mcp::cluster::Cluster::connect(config).map(Some)
    }
}

/// A node name unique per process: the host's name and the process id.
fn default_node_name() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: gethostname writes at most buf.len() bytes into our buffer.
    let ok = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) } == 0;
    let len = buf.iter().position(|b| *b == 0).unwrap_or(buf.len());
    let host = if ok { String::from_utf8_lossy(&buf[..len]).replace('.', "-") } else { String::new() };
    format!("{}-{}", if host.is_empty() { "node" } else { &host }, std::process::id())
}

/// A connection for the export/import commands (not a node: it serves nothing).
fn connect_tool(urls: &str, namespace: &str) -> anyhow::Result<Arc<physics_mcp::cluster::Cluster>> {
    let mut config = physics_mcp::cluster::ClusterConfig::new(urls, &format!("cli-{}", std::process::id()));
    config.namespace = namespace.into();
    config.serves = false;
    physics_mcp::cluster::Cluster::connect(config)
}

#[derive(Subcommand)]
enum Cmd {
    /// Serve MCP over streamable HTTP at /mcp.
    Serve {
        /// Address to bind (loopback by default; port 0 picks a free port).
        #[arg(long, default_value = "127.0.0.1:8000")]
        bind: SocketAddr,
        /// Require `Authorization: Bearer <TOKEN>` on every request (visible in `ps`: prefer
        /// --token-file or PHYSICS_MCP_TOKEN).
        #[arg(long, conflicts_with = "token_file")]
        token: Option<String>,
        /// Require the bearer token written on this file's first line.
        #[arg(long, value_name = "PATH")]
        token_file: Option<PathBuf>,
        /// Allow this browser Origin besides loopback ones (repeatable).
        #[arg(long)]
        allow_origin: Vec<String>,
        /// Live MCP sessions at most; past it a new one ends the least recently used idle one.
        #[arg(long, default_value_t = physics_mcp::mcp::session_limit::DEFAULT_MAX_SESSIONS, value_parser = clap::value_parser!(usize))]
        max_sessions: usize,
        /// Live MCP sessions of one client (bearer token, else address) at most.
        #[arg(long, default_value_t = physics_mcp::mcp::session_limit::DEFAULT_MAX_SESSIONS_PER_CLIENT, value_parser = clap::value_parser!(usize))]
        max_sessions_per_client: usize,
        #[command(flatten)]
        common: Common,
        #[command(flatten)]
        cluster: ClusterArgs,
    },
    /// Write a simulation's log from a cluster into a SQLite file that `replay` verifies.
    Export {
        /// The cluster: nats://HOST:PORT[,…].
        cluster: String,
        /// The namespace the nodes use (their --cluster-namespace).
        #[arg(long, default_value = "pmcp")]
        cluster_namespace: String,
        /// The simulation.
        sim_id: String,
        /// The file to write (refused if it exists).
        out: PathBuf,
    },
    /// Put a simulation's SQLite log into a cluster (verified first; an id that exists there is refused).
    Import {
        /// The cluster: nats://HOST:PORT[,…].
        cluster: String,
        /// The namespace the nodes use (their --cluster-namespace).
        #[arg(long, default_value = "pmcp")]
        cluster_namespace: String,
        /// A simulation's SQLite log.
        file: PathBuf,
        /// The id to give it in the cluster.
        #[arg(long = "as", value_name = "NEW_ID")]
        new_id: Option<String>,
    },
    /// Serve MCP over stdin/stdout (for clients that start the server themselves).
    Stdio {
        #[command(flatten)]
        common: Common,
    },
    /// Refold a simulation log in a fresh world, checking every recorded hash; exits
    /// non-zero at the first divergence, naming it.
    Replay {
        /// A simulation's SQLite log (e.g. physics-mcp-data/<id>.sqlite) or a saved .json.
        file: PathBuf,
        /// Stop after this event (logs only).
        #[arg(long)]
        until: Option<u64>,
        /// Print the summary (or the divergence) as JSON.
        #[arg(long)]
        json: bool,
        /// Also write the interval's samples (poses, velocities, joints) to this .csv or .jsonl.
        #[arg(long)]
        trajectory: Option<PathBuf>,
        /// Also write the interval as an MCAP file for Foxglove (/scene, /tf on simulated time).
        #[arg(long, value_name = "OUT.mcap")]
        mcap: Option<PathBuf>,
        /// With --mcap: also the contact points at every sample, on /contacts.
        #[arg(long, requires = "mcap")]
        contacts: bool,
        /// Instead of checking, write the head's chain (or --from..--to) as a looping GIF.
        #[arg(long, value_name = "OUT.gif")]
        render: Option<PathBuf>,
        /// The interval and sampling for --trajectory, --mcap and --render.
        #[command(flatten)]
        interval: physics_mcp::cli::IntervalArgs,
        /// Frame size for --render, WxH.
        #[arg(long, default_value = "320x240", value_parser = parse_size)]
        size: (u32, u32),
        #[arg(long)]
        force: bool,
    },
    /// Write a recorded session as one self-contained, offline HTML page: header, timeline of
    /// every event with thumbnails, the run as an animation, height and speed plots.
    Report {
        /// A simulation's SQLite log.
        file: PathBuf,
        /// The page to write.
        #[arg(short = 'o', long = "output", value_name = "OUT.html")]
        out: PathBuf,
        #[arg(long)]
        force: bool,
    },
    /// Print a log's events as a table.
    History {
        /// A simulation's SQLite log.
        file: PathBuf,
    },
    /// Call one tool on a running server and print its result (exit 1 if the tool refused).
    Call {
        /// The server's MCP endpoint, e.g. http://127.0.0.1:8000/mcp.
        url: String,
        /// The tool, e.g. create_simulation.
        tool: String,
        /// Its arguments as a JSON object.
        #[arg(default_value = "{}")]
        args: String,
        /// Bearer token, when the server requires one (visible in `ps`: prefer --token-file
        /// or PHYSICS_MCP_TOKEN).
        #[arg(long, conflicts_with = "token_file")]
        token: Option<String>,
        /// Send the bearer token written on this file's first line.
        #[arg(long, value_name = "PATH")]
        token_file: Option<PathBuf>,
    },
    /// Name the first event where two logs diverge (exit 1 if they do).
    Diff {
        /// First log.
        a: PathBuf,
        /// Second log.
        b: PathBuf,
    },
}

/// `WxH` → (W, H).
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("--size must be WxH, e.g. 320x240; got {s}"))?;
    let side = |v: &str| v.trim().parse::<u32>().ok().filter(|n| *n >= 1).ok_or_else(|| format!("--size must be WxH with sides >= 1; got {s}"));
    Ok((side(w)?, side(h)?))
}

/// A progress bar on a terminal (hidden otherwise), for long re-simulations and renders.
fn progress_bar(what: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(0);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} steps ({eta})") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(what.to_string());
    bar
}

/// `replay FILE --render OUT.gif`.
fn run_render(file: &Path, out: &Path, span: physics_mcp::seeing::report::Span, every: Option<u64>, size: (u32, u32), force: bool) -> anyhow::Result<()> {
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("gif")) {
        anyhow::bail!("--render writes a GIF: the file name must end in .gif; got {}", out.display());
    }
    let bar = progress_bar("rendering");
    let started = std::time::Instant::now();
    let anim = physics_mcp::seeing::report::render_gif(file, span, every, size, |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    });
    bar.finish_and_clear();
    let anim = anim.map_err(anyhow::Error::msg)?;
    physics_mcp::files::write::write_operator_file(out, &anim.gif, force).map_err(anyhow::Error::msg)?;
    println!(
        "wrote {}: {} frames {}x{}, {} bytes, plays {:.2} s ({:.2} s simulated), camera {}, in {:.2} s",
        out.display(),
        anim.frames,
        size.0,
        size.1,
        anim.gif.len(),
        anim.duration_s,
        anim.simulated_s,
        serde_json::to_string(&anim.camera).unwrap_or_default(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `report FILE -o OUT.html`.
fn run_report(file: &Path, out: &Path, force: bool) -> anyhow::Result<()> {
    let bar = progress_bar("re-simulating");
    let started = std::time::Instant::now();
    let story = physics_mcp::seeing::report::gather(file, |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    });
    bar.finish_and_clear();
    let page = physics_mcp::seeing::report::html(&story.map_err(anyhow::Error::msg)?).map_err(anyhow::Error::msg)?;
    physics_mcp::files::write::write_operator_file(out, page.as_bytes(), force).map_err(anyhow::Error::msg)?;
    println!("wrote {}: {} bytes, {:.2} s", out.display(), page.len(), started.elapsed().as_secs_f64());
    Ok(())
}

fn run_replay(file: &Path, until: Option<u64>, json: bool) -> anyhow::Result<bool> {
    use std::io::IsTerminal;
    // Before anything else: a log made by another engine build may not reproduce its hashes.
    let builds = physics_mcp::log::replay::engine_builds(file)?;
    if let (false, Some(warning)) = (json, builds.warning()) {
        println!("{warning}");
    }
    let bar = if std::io::stderr().is_terminal() {
        indicatif::ProgressBar::new(0)
    } else {
        indicatif::ProgressBar::hidden()
    };
    let started = std::time::Instant::now();
    let progress = |done, total| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let is_json = file.extension().is_some_and(|x| x == "json");
    let result = if is_json {
        physics_mcp::log::replay::replay_saved(file, progress)
    } else {
        physics_mcp::log::replay::replay(file, until, progress)
    };
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    match result {
        Ok(s) => {
            if json {
                println!("{}", serde_json::json!({"ok": true, "engine_builds": builds, "summary": s, "seconds": seconds}));
            } else {
                println!(
                    "ok: {} events ({} state-changing, {} reads checked, {} snapshots), {} steps, final hash {}, {:.2} s",
                    s.events, s.state_events, s.reads_checked, s.snapshots_checked, s.steps, s.final_hash, seconds
                );
            }
            Ok(true)
        }
        Err(physics_mcp::log::replay::ReplayError::Diverged(d)) => {
            if json {
                println!("{}", serde_json::json!({"ok": false, "engine_builds": builds, "divergence": d}));
            } else {
                eprintln!(
                    "DIVERGED at seq {} ({}), {}: expected {}, got {}\n  arguments: {}",
                    d.seq, d.tool, d.what, d.expected, d.actual, d.arguments
                );
            }
            Ok(false)
        }
        Err(e) => Err(e.into()),
    }
}

fn print_history(file: &Path) -> anyhow::Result<()> {
    println!("{:>6}  {:<8} {:>6}  {:<24} {:<3} {:<12}  summary", "seq", "kind", "parent", "tool", "ok", "state");
    for e in physics_mcp::log::replay::events(file)? {
        // A read shows what it returned (schema v3), anything else its result or refusal.
        let summary = e.result.as_deref().or(e.summary.as_deref()).unwrap_or("");
        let summary: String = summary.chars().take(70).collect();
        println!(
            "{:>6}  {:<8} {:>6}  {:<24} {:<3} {:<12}  {}{}",
            e.seq,
            e.kind.as_str(),
            e.parent.map(|p| p.to_string()).unwrap_or_default(),
            e.tool,
            if e.ok { "yes" } else { "no" },
            // The first 12 characters, not bytes: the log may be anyone's file, and slicing
            // a non-ASCII hash at byte 12 could split a character.
            e.state_hash.chars().take(12).collect::<String>(),
            if e.inherited { "[inherited] " } else { "" },
            summary
        );
    }
    Ok(())
}

fn open_registry(c: Common, cluster: Option<Arc<physics_mcp::cluster::Cluster>>) -> anyhow::Result<Arc<Registry>> {
    let dirs = physics_mcp::log::default_dirs::choose(c.data, c.workspace)?;
    if let Some(note) = &dirs.note {
        // The first log line, in one write (a client's log shows it whole).
        use std::io::Write;
        let _ = std::io::stderr().lock().write_all(format!("{note}\n").as_bytes());
    }
    Ok(Arc::new(Registry::open_with(
        Config {
            data_dir: dirs.data,
            workspace: dirs.workspace,
            limits: c.limits.into(),
            sync: c.sync,
        },
        cluster,
    )?))
}

/// `export` and `import`, which talk to a cluster and nothing else.
fn run_portable(command: &Cmd) -> Option<anyhow::Result<()>> {
    use physics_mcp::cluster::portable;
    Some(match command {
        Cmd::Export { cluster, cluster_namespace, sim_id, out } => connect_tool(cluster, cluster_namespace).and_then(|c| {
            let events = portable::export(&c, sim_id, out).map_err(anyhow::Error::msg)?;
            println!("wrote {}: simulation {sim_id}, {events} events", out.display());
            Ok(())
        }),
        Cmd::Import { cluster, cluster_namespace, file, new_id } => connect_tool(cluster, cluster_namespace).and_then(|c| {
            let id = portable::import(&c, file, new_id.as_deref()).map_err(anyhow::Error::msg)?;
            println!("imported {} as simulation {id}", file.display());
            Ok(())
        }),
        _ => return None,
    })
}

/// A write past the file-size limit (RLIMIT_FSIZE) raises SIGXFSZ, whose default action kills
/// the process. Ignored, the write fails with EFBIG instead: the call is refused and the
/// server keeps serving (tests/durability/full_disk.rs).
fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to SIG_IGN, before any thread is started here,
    // touches no memory of ours.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

fn main() {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .init();
    let cli = Cli::parse();
    #[cfg(debug_assertions)]
    let _failpoints = physics_mcp::failpoints::setup();
    ignore_file_size_signal();
    // The built-in model library: only this binary links its archive (test binaries that never
    // install it carry none of its bytes).
    if let Err(e) = physics_mcp::files::library::install(physics_models::ARCHIVE) {
        eprintln!("physics-mcp: the built-in model library is damaged: {e}");
        std::process::exit(2);
    }
    if let Err(e) = physics_mcp::cli::step_on_threads(usize::from(cli.threads)) {
        eprintln!("physics-mcp: --threads: {e}");
        std::process::exit(2);
    }
    // One async worker: the async side only moves small JSON messages between hyper, rmcp's
    // session tasks and our handlers (simulation work runs on the blocking pool, reads take a
    // try_lock), and with one worker those hand-offs stay on one thread instead of waking
    // another: get_object_state p50 over HTTP 0.37 -> 0.31 ms on two cores (benches/physics.rs).
    if let Some(done) = run_portable(&cli.command) {
        if let Err(e) = done {
            eprintln!("physics-mcp: {e:#}");
            std::process::exit(1);
        }
        return;
    }
    // The cluster's own runtime is started outside the server's (one may not block on a
    // runtime from inside another).
    let cluster = match &cli.command {
        Cmd::Serve { cluster, .. } => cluster.connect(),
        _ => Ok(None),
    };
    let cluster = match cluster {
        Ok(c) => c,
        Err(e) => {
            eprintln!("physics-mcp: {e:#}");
            std::process::exit(2);
        }
    };
    let result = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .map_err(anyhow::Error::from)
        .and_then(|rt| {
            let result = rt.block_on(async {
                match cli.command {
                    Cmd::Serve {
                        bind,
                        token,
                        token_file,
                        allow_origin,
                        max_sessions,
                        max_sessions_per_client,
                        common,
                        ..
                    } => {
                        let token = physics_mcp::secret::token(token, token_file.as_deref()).map_err(anyhow::Error::msg)?;
                        let reg = open_registry(common, cluster)?;
                        physics_mcp::mcp::PhysicsServer::start_sweepers(&reg)?;
                        serve_http(reg, HttpOptions { bind, token, allow_origin, max_sessions, max_sessions_per_client }).await
                    }
                    Cmd::Stdio { common } => serve_stdio(open_registry(common, None)?).await,
                    Cmd::Replay { file, render: Some(out), interval, size, force, .. } => {
                        let span = physics_mcp::seeing::report::Span { from: interval.from, to: interval.to };
                        run_render(&file, &out, span, interval.every, size, force)
                    }
                    Cmd::Report { file, out, force } => run_report(&file, &out, force),
                    Cmd::Replay { file, until, json, trajectory, mcap, contacts, interval, force, .. } => {
                        if !run_replay(&file, until, json)? {
                            std::process::exit(1);
                        }
                        if let Some(out) = trajectory {
                            let t = physics_mcp::log::replay::write_trajectory(&file, &out, &interval, force)
                                .map_err(|e| anyhow::anyhow!("--trajectory: {e}"))?;
                            eprintln!(
                                "trajectory: {} samples of {} objects (seq {} to {}, every {} steps) written to {}",
                                t.samples, t.objects.len(), t.from_seq, t.to_seq, t.every, out.display()
                            );
                        }
                        if let Some(out) = mcap {
                            let (t, bytes) = physics_mcp::log::replay::write_mcap(&file, &out, &interval, contacts, force)
                                .map_err(|e| anyhow::anyhow!("--mcap: {e}"))?;
                            eprintln!(
                                "mcap: {} samples (seq {} to {}, every {} steps), {bytes} bytes, written to {}",
                                t.samples, t.from_seq, t.to_seq, t.every, out.display()
                            );
                        }
                        Ok(())
                    }
                    Cmd::History { file } => print_history(&file),
                    // Run before this runtime starts (run_portable).
                    Cmd::Export { .. } | Cmd::Import { .. } => Ok(()),
                    Cmd::Call { url, tool, args, token, token_file } => {
                        let token = physics_mcp::secret::token(token, token_file.as_deref()).map_err(anyhow::Error::msg)?;
                        let called = physics_mcp::client::call(&url, &tool, &args, token.as_deref()).await?;
                        println!("{}", called.output);
                        if called.is_error {
                            std::process::exit(1);
                        }
                        Ok(())
                    }
                    Cmd::Diff { a, b } => match physics_mcp::log::replay::diff(&a, &b)? {
                        Some(d) => {
                            println!("{d}");
                            std::process::exit(1);
                        }
                        None => {
                            println!("the logs are identical");
                            Ok(())
                        }
                    },
                }
            });
            // A blocking task that has not stopped (it commits its own events) does not hold
            // the exit: shutdown takes at most `shutdown::DEADLINE` (docs/guarantees).
            rt.shutdown_timeout(std::time::Duration::from_millis(300));
            result
        });
    if let Err(e) = result {
        eprintln!("physics-mcp: {e:#}");
        std::process::exit(1);
    }
}
