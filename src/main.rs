//! The `physics-mcp` command line: `serve` (HTTP), `stdio`.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;

use clap::{Parser, Subcommand};
use physics_mcp::limits::Limits;
use physics_mcp::mcp::transport::{serve_http, serve_stdio, HttpOptions};
use physics_mcp::sim::{Config, Registry};
use physics_mcp::store::SyncMode;

/// An MCP server for deterministic, replayable rigid-body physics (rapier3d).
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

/// Where simulations live and how they are limited (shared by serve and stdio).
#[derive(clap::Args)]
struct Common {
    /// Directory holding one SQLite log per simulation (exclusively locked while running).
    #[arg(long, default_value = "./physics-mcp-data")]
    data: PathBuf,
    /// Directory that URDF, save and load paths are confined to.
    #[arg(long, default_value = "./physics-mcp-workspace")]
    workspace: PathBuf,
    /// Durability: `normal` survives a killed process; `full` also fsyncs for power loss.
    #[arg(long, value_enum, default_value_t = SyncMode::Normal)]
    sync: SyncMode,
    #[command(flatten)]
    limits: Limits,
}

#[derive(Subcommand)]
enum Cmd {
    /// Serve MCP over streamable HTTP at /mcp.
    Serve {
        /// Address to bind (loopback by default; port 0 picks a free port).
        #[arg(long, default_value = "127.0.0.1:8000")]
        bind: SocketAddr,
        /// Require `Authorization: Bearer <TOKEN>` on every request.
        #[arg(long)]
        token: Option<String>,
        /// Allow this browser Origin besides loopback ones (repeatable).
        #[arg(long)]
        allow_origin: Vec<String>,
        #[command(flatten)]
        common: Common,
    },
    /// Serve MCP over stdin/stdout (for clients that start the server themselves).
    Stdio {
        #[command(flatten)]
        common: Common,
    },
}

fn open_registry(c: Common) -> anyhow::Result<Arc<Registry>> {
    Ok(Arc::new(Registry::open(Config {
        data_dir: c.data,
        workspace: c.workspace,
        limits: c.limits,
        sync: c.sync,
    })?))
}

fn main() {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .init();
    let cli = Cli::parse();
    let result = tokio::runtime::Runtime::new()
        .map_err(anyhow::Error::from)
        .and_then(|rt| {
            rt.block_on(async {
                match cli.command {
                    Cmd::Serve {
                        bind,
                        token,
                        allow_origin,
                        common,
                    } => {
                        let reg = open_registry(common)?;
                        serve_http(reg, HttpOptions { bind, token, allow_origin }).await
                    }
                    Cmd::Stdio { common } => serve_stdio(open_registry(common)?).await,
                }
            })
        });
    if let Err(e) = result {
        eprintln!("physics-mcp: {e:#}");
        std::process::exit(1);
    }
}
