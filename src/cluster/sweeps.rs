//! run_sweep's variants spread over a cluster's nodes, the NATS side (docs/cluster.md "Sweeps
//! across nodes").
//!
//! The sweeping node puts one work item per variant on the work-queue stream `NS_sweeps`
//! (subject `NS.sweep.work.SWEEP`). Every node's sweepers pull from one shared durable consumer,
//! one item at a time and only when free, so the variants spread over whatever cores the
//! cluster has free. While a variant runs its worker sends in-progress acks; a node that dies
//! stops sending them and JetStream gives its items to other sweepers after [`ACK_WAIT`].
//! Progress and results travel on core NATS: progress on `NS.sweep.progress.SWEEP`, results as
//! requests on `NS.sweep.done.SWEEP`, which the sweeping node answers by what a result is —
//! variant and attempt (one run of it, with its kept fork): the first attempt for a variant is
//! accepted, and so is any repeat of that attempt (a worker asking again after an answer it
//! never got); another attempt (a redelivered item run again) is unwanted.
//! `NS.sweep.cancel.SWEEP` tells every node that a sweep is over, finished or cancelled (its
//! running variants stop, its left-over items are dropped) and which kept forks to destroy.
//! What became of a sweep is also written once, durably, in `NS_sweep_verdicts` (the kept forks
//! its reply names; none if it was refused, cancelled or abandoned): a worker that holds a kept
//! fork and never heard an answer follows the verdict, and when the sweeping node's lease is
//! gone before it wrote one, the worker writes "abandoned" itself — the first write wins, so a
//! fork a reply names is never destroyed and a fork no reply names is never kept.
//! A payload too large for one message goes through the object store, as a large commit does.

use std::future::Future;
use std::sync::{mpsc, Arc};
use std::time::Duration;

use async_nats::client::RequestErrorKind;
use async_nats::jetstream::consumer::{pull, AckPolicy, PullConsumer};
use async_nats::jetstream::message::PublishMessage;
use async_nats::jetstream::{self, stream, AckKind};
use async_nats::Subject;
use bytes::Bytes;
use futures_util::StreamExt;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::{patiently, Cluster, INLINE_COMMIT_MAX};
use crate::outputs::SweptVariant;
use crate::sim::sweep::Observe;
use crate::value::Refusal;

/// How long a pulled variant may go without any acknowledgement before JetStream gives it to
/// another sweeper: how long the variants of a killed node wait before they run elsewhere.
pub const ACK_WAIT: Duration = Duration::from_secs(5);

/// How often a running variant's in-progress ack goes out: a fifth of [`ACK_WAIT`], so a few
/// late or lost ones on a loaded machine do not make JetStream think the node is dead.
pub const HEARTBEAT: Duration = Duration::from_secs(1);

/// How long one pull waits for an item: how soon an idle sweeper notices a shutdown.
const PULL_WAIT: Duration = Duration::from_secs(2);

/// How long a worker waits for the sweeping node to answer one request.
const ANSWER_WAIT: Duration = Duration::from_secs(5);

/// How long a sweep's verdict is kept: far longer than any worker waits for one.
const VERDICT_LIFE: Duration = Duration::from_secs(24 * 3600);

/// The durable consumer all nodes share: one queue, each item to one sweeper at a time.
const CONSUMER: &str = "sweepers";

/// The sweeping node's answers, and its reply to a ping (a request with an empty payload).
const ACCEPTED: &[u8] = b"accepted";
const UNWANTED: &[u8] = b"unwanted";
const HERE: &[u8] = b"here";

/// One variant to run, as the sweeping node sends it: everything a node needs to fork the
/// swept simulation at `at` and do what a sweep on one node does with the variant.
#[derive(Serialize, Deserialize, Clone, Debug)]
pub struct WorkItem {
    /// The sweep (a UUID): names its subjects.
    pub sweep_id: String,
    /// The swept simulation, whose subject holds the state to fork.
    pub parent_id: String,
    /// The seq the sweep forks at (the swept simulation's head when it began).
    pub at: u64,
    /// The variant's index in the request.
    pub index: usize,
    /// The variant's `[{tool, arguments}]` exactly as the client sent them, decided again by
    /// the node that runs it (files they name are read from the shared workspace).
    pub calls: serde_json::Value,
    /// Steps after the calls.
    pub steps: u64,
    /// What to report of the variant.
    pub observe: Observe,
    /// Keep the fork, as a simulation of the node that runs it.
    pub keep: bool,
    /// Steps between progress messages (about 100 for the whole sweep).
    pub report_every: u64,
    /// The sweeping node's engine build: a node of another build (a rolling upgrade) gives the
    /// item back, since its results could differ.
    pub engine: String,
    /// The sweeping node: while its lease lives, a worker waits for the sweep's answer or
    /// verdict rather than give its result up.
    #[serde(default)]
    pub from: String,
    /// The sweeping node's incarnation (its lease's token) when it sent the item.
    #[serde(default)]
    pub token: String,
}

/// A run's result, as a worker reports it.
#[derive(Serialize, Deserialize, Debug)]
pub struct Report {
    /// The variant's index.
    pub index: usize,
    /// This run of the variant (a UUID): a repeat of a report is answered as the first was.
    #[serde(default)]
    pub attempt: String,
    /// The node that ran it.
    pub node: String,
    /// The kept fork's id, when kept (the reporting node holds it).
    pub fork: Option<String>,
    /// What the variant gave, or why it was refused.
    pub outcome: Result<SweptVariant, Refusal>,
}

/// The steps a run of a variant has taken so far.
#[derive(Serialize, Deserialize)]
struct Progress {
    index: usize,
    steps: u64,
}

/// A sweep is over: its running variants stop, and these kept forks are destroyed.
#[derive(Serialize, Deserialize, Default, Debug)]
pub struct Over {
    /// Kept forks to destroy, on whichever node holds them.
    #[serde(default)]
    pub discard: Vec<String>,
}

/// What became of a sweep, written once (`SweepQueue::decide`): the kept forks its reply
/// names; none when it was refused, cancelled or abandoned.
#[derive(Serialize, Deserialize, Default, Debug, Clone)]
pub struct Verdict {
    /// The forks that stay (every other fork of the sweep is destroyed by the node holding it).
    #[serde(default)]
    pub kept: Vec<String>,
    /// Written by a worker that found the sweeping node's lease gone before it decided.
    #[serde(default)]
    pub abandoned: bool,
}

/// A payload that went to the object store; the message names it.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Stored {
    stored: String,
}

/// What the sweeping node said of a report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer {
    /// The first result for its variant: it counts, a kept fork stays.
    Accepted,
    /// Another run's result came first: a kept fork goes.
    Unwanted,
    /// Nobody listens for the sweep (it is over, its node died — or is reconnecting): the
    /// verdict, or the sweeping node's lease, decides.
    Gone,
    /// No answer: whether it counted is unknown until an answer, the verdict or the sweeping
    /// node's lease says.
    Silent,
}

/// The work-queue stream of a namespace's sweeps.
fn stream_name(namespace: &str) -> String {
    format!("{namespace}_sweeps")
}

/// This node's end of the sweep queue: the stream and the shared consumer, and a core NATS
/// client for progress, results and the end of sweeps.
pub struct SweepQueue {
    cluster: Arc<Cluster>,
    consumer: PullConsumer,
    client: async_nats::Client,
    /// `NS_sweep_verdicts`: what became of each sweep, written once.
    verdicts: async_nats::jetstream::kv::Store,
}

impl SweepQueue {
    /// Creates the stream and the consumer, or opens them when another node did.
    pub fn open(cluster: &Arc<Cluster>) -> Result<SweepQueue, String> {
        let (js, ns, replicas) = (cluster.js.clone(), cluster.config.namespace.clone(), cluster.config.replicas);
        let (consumer, verdicts) = cluster.run(async move {
            // Items live until their sweep is over (no age limit: a sweep may run for hours);
            // the items of a sweeping node that died are dropped by the workers that pull them.
            let config = stream::Config {
                name: stream_name(&ns),
                subjects: vec![format!("{ns}.sweep.work.>")],
                retention: stream::RetentionPolicy::WorkQueue,
                num_replicas: replicas,
                ..Default::default()
            };
            let mut stream = patiently(|| js.get_or_create_stream(config.clone()))
                .await
                .map_err(|e| format!("stream {}: {e}", config.name))?;
            // A stream made by an earlier release dropped items after an hour: lifted.
            if stream.cached_info().config.max_age != Duration::ZERO {
                let mut lifted = stream.cached_info().config.clone();
                lifted.max_age = Duration::ZERO;
                patiently(|| js.update_stream(lifted.clone())).await.map_err(|e| format!("stream {}: {e}", config.name))?;
                stream = patiently(|| js.get_stream(config.name.clone())).await.map_err(|e| format!("stream {}: {e}", config.name))?;
            }
            let pulling = pull::Config {
                durable_name: Some(CONSUMER.into()),
                ack_policy: AckPolicy::Explicit,
                ack_wait: ACK_WAIT,
                max_deliver: -1,
                filter_subject: format!("{ns}.sweep.work.>"),
                ..Default::default()
            };
            let consumer = patiently(|| stream.get_or_create_consumer(CONSUMER, pulling.clone()))
                .await
                .map_err(|e| format!("consumer {CONSUMER} of {}: {e}", config.name))?;
            let verdicts = super::open_bucket(
                &js,
                async_nats::jetstream::kv::Config {
                    bucket: format!("{ns}_sweep_verdicts"),
                    history: 1,
                    max_age: VERDICT_LIFE,
                    num_replicas: replicas,
                    ..Default::default()
                },
            )
            .await
            .map_err(|e| e.to_string())?;
            Ok::<_, String>((consumer, verdicts))
        })?;
        Ok(SweepQueue { cluster: cluster.clone(), consumer, client: cluster.js.client(), verdicts })
    }

    /// Writes what became of `sweep`, unless a verdict is there already; returns the verdict
    /// that holds (this one, or the one written first).
    pub fn decide(&self, sweep: &str, verdict: &Verdict) -> Result<Verdict, String> {
        let (verdicts, key) = (self.verdicts.clone(), sweep.to_string());
        let bytes: Bytes = serde_json::to_vec(verdict).map_err(|e| e.to_string())?.into();
        let mine = verdict.clone();
        self.cluster.run_for(Duration::from_secs(30), async move {
            patiently(|| async {
                match verdicts.create(&key, bytes.clone()).await {
                    Ok(_) => Ok(mine.clone()),
                    Err(e) if e.kind() == async_nats::jetstream::kv::CreateErrorKind::AlreadyExists => {
                        match super::lease::leader_entry(&verdicts, &key).await? {
                            Some((b, _)) => serde_json::from_slice(&b).map_err(|e| e.to_string()),
                            None => Err("a sweep's verdict vanished".to_string()),
                        }
                    }
                    Err(e) => Err(e.to_string()),
                }
            })
            .await
        })?
    }

    /// What became of `sweep`, if it was decided.
    pub fn verdict(&self, sweep: &str) -> Result<Option<Verdict>, String> {
        let (verdicts, key) = (self.verdicts.clone(), sweep.to_string());
        self.cluster.run_for(Duration::from_secs(30), async move {
            let got = super::lease::leader_entry(&verdicts, &key).await?;
            got.map(|(b, _)| serde_json::from_slice(&b).map_err(|e| e.to_string())).transpose()
        })?
    }

    /// Whether the node that sent `item` still holds its lease (so its sweep may still be
    /// answered). A cluster that cannot say is taken as yes: the worker asks again later.
    pub fn sweeping_node_alive(&self, item: &WorkItem) -> bool {
        if item.token.is_empty() {
            return false;
        }
        let (cluster, node, token) = (self.cluster.clone(), item.from.clone(), item.token.clone());
        let alive = self.cluster.run_for(Duration::from_secs(30), async move { cluster.node_alive(&node, &token).await });
        !matches!(alive, Ok(Ok(false)))
    }

    /// This node's name and incarnation, for the items of its sweeps.
    pub fn signature(&self) -> (String, String) {
        (self.cluster.config.node.clone(), self.cluster.incarnation().unwrap_or_default())
    }

    /// This node's name (which the variants it runs are logged and reported under).
    pub fn node(&self) -> &str {
        &self.cluster.config.node
    }

    /// `NS.sweep.KIND.SWEEP`.
    fn subject(&self, kind: &str, sweep: &str) -> String {
        format!("{}.sweep.{kind}.{sweep}", self.cluster.config.namespace)
    }

    /// Runs `f` on the cluster's runtime without waiting for it.
    fn spawn(&self, f: impl Future<Output = ()> + Send + 'static) -> Option<tokio::task::JoinHandle<()>> {
        self.cluster.rt.as_ref().map(|rt| rt.spawn(f))
    }

    /// `value` as a message payload: its JSON, or (too large for a message) the name of the
    /// object holding it.
    fn pack<T: Serialize>(&self, value: &T) -> Result<(Vec<u8>, Option<String>), String> {
        let json = serde_json::to_vec(value).map_err(|e| e.to_string())?;
        if json.len() <= INLINE_COMMIT_MAX {
            return Ok((json, None));
        }
        let name = format!("sweep/{}", crate::digest::content_hash(&json));
        self.cluster.put_object(&name, &json)?;
        let stored = serde_json::to_vec(&Stored { stored: name.clone() }).map_err(|e| e.to_string())?;
        Ok((stored, Some(name)))
    }

    /// A payload `pack` made: the value, and the object it came from, if any. Err(None): the
    /// payload is not one (it never will be); Err(Some(why)): the object could not be read.
    fn unpack<T: DeserializeOwned>(&self, payload: &[u8]) -> Result<(T, Option<String>), Option<String>> {
        if let Ok(Stored { stored }) = serde_json::from_slice::<Stored>(payload) {
            let json = self.cluster.get_object(&stored).map_err(Some)?;
            return serde_json::from_slice(&json).map(|t| (t, Some(stored))).map_err(|_| None);
        }
        serde_json::from_slice(payload).map(|t| (t, None)).map_err(|_| None)
    }

    /// Deletes objects `pack` made, without waiting.
    fn delete_objects(&self, names: Vec<String>) {
        if names.is_empty() {
            return;
        }
        let objects = self.cluster.objects.clone();
        self.spawn(async move {
            for name in names {
                let _ = objects.delete(&name).await;
            }
        });
    }

    /// The next variant for this sweeper, waiting a little for one (None: none came).
    pub fn next(&self) -> Result<Option<Delivery<'_>>, String> {
        let consumer = self.consumer.clone();
        let message = self.cluster.run(async move {
            let mut batch =
                consumer.fetch().max_messages(1).expires(PULL_WAIT).messages().await.map_err(|e| e.to_string())?;
            batch.next().await.transpose().map_err(|e| e.to_string())
        })?;
        let Some(message) = message else { return Ok(None) };
        let settle = |kind: AckKind| {
            let m = message.clone();
            self.cluster.run(async move {
                let _ = m.ack_with(kind).await;
            })
        };
        match self.unpack::<WorkItem>(&message.payload) {
            Ok((item, _)) => Ok(Some(Delivery { queue: self, message, item, beat: None })),
            Err(None) => {
                tracing::warn!("a sweep's work item does not decode; dropped");
                settle(AckKind::Term);
                Ok(None)
            }
            Err(Some(why)) => {
                settle(AckKind::Nak(None));
                Err(why)
            }
        }
    }

    /// Tells the sweeping node how many steps a run of variant `index` has taken (a progress
    /// message; lost ones only make progress coarser).
    pub fn progress(&self, sweep: &str, index: usize, steps: u64) {
        let (client, subject) = (self.client.clone(), self.subject("progress", sweep));
        let payload = serde_json::to_vec(&Progress { index, steps }).unwrap_or_default();
        self.spawn(async move {
            let _ = client.publish(subject, payload.into()).await;
        });
    }

    /// A run's result packed for `report` (the same bytes every time it is asked again).
    pub fn packed(&self, report: &Report) -> Result<Vec<u8>, String> {
        self.pack(report).map(|(payload, _)| payload)
    }

    /// Sends a packed result to the sweeping node once and returns its answer.
    pub fn report(&self, sweep: &str, packed: &[u8]) -> Answer {
        let (client, subject, payload) = (self.client.clone(), self.subject("done", sweep), Bytes::copy_from_slice(packed));
        self.cluster.run(async move {
            match tokio::time::timeout(ANSWER_WAIT, client.request(subject, payload)).await {
                Ok(Ok(reply)) if reply.payload.as_ref() == UNWANTED => Answer::Unwanted,
                Ok(Ok(_)) => Answer::Accepted,
                Ok(Err(e)) if e.kind() == RequestErrorKind::NoResponders => Answer::Gone,
                _ => Answer::Silent,
            }
        })
    }

    /// Calls `heard(sweep, over)` for every sweep said to be over, on the cluster's runtime:
    /// `heard` must not block.
    pub fn on_over(&self, heard: impl Fn(String, Over) + Send + Sync + 'static) -> Result<(), String> {
        let (client, subject) = (self.client.clone(), self.subject("cancel", "*"));
        let mut over = self.cluster.run(async move { client.subscribe(subject).await.map_err(|e| e.to_string()) })?;
        self.spawn(async move {
            while let Some(m) = over.next().await {
                let sweep = m.subject.rsplit('.').next().unwrap_or_default().to_string();
                heard(sweep, serde_json::from_slice(&m.payload).unwrap_or_default());
            }
        });
        Ok(())
    }

    /// Tells every node that `sweep` is over and which kept forks to destroy.
    pub fn tell_over(&self, sweep: &str, discard: Vec<String>) {
        let (client, subject) = (self.client.clone(), self.subject("cancel", sweep));
        let payload = serde_json::to_vec(&Over { discard }).unwrap_or_default();
        self.cluster.run(async move {
            let _ = client.publish(subject, payload.into()).await;
            let _ = client.flush().await;
        });
    }

    /// Begins a sweep on the queue: listens for its progress and results (before any item is
    /// sent, so none is missed).
    pub fn begin(&self, sweep: &str) -> Result<SweepCall<'_>, String> {
        let (client, done, progress) = (self.client.clone(), self.subject("done", sweep), self.subject("progress", sweep));
        let (mut reports, mut steps) = self.cluster.run(async move {
            let reports = client.subscribe(done).await.map_err(|e| e.to_string())?;
            let steps = client.subscribe(progress).await.map_err(|e| e.to_string())?;
            client.flush().await.map_err(|e| e.to_string())?;
            Ok::<_, String>((reports, steps))
        })?;
        let (tx, heard) = mpsc::channel();
        let (to_steps, client) = (tx.clone(), self.client.clone());
        let forward_reports = self.spawn(async move {
            while let Some(m) = reports.next().await {
                if m.payload.is_empty() {
                    if let Some(reply) = m.reply {
                        let _ = client.publish(reply, HERE.into()).await;
                    }
                } else if tx.send(Raw::Report(m.payload, m.reply)).is_err() {
                    break;
                }
            }
        });
        let forward_steps = self.spawn(async move {
            while let Some(m) = steps.next().await {
                if let Ok(p) = serde_json::from_slice::<Progress>(&m.payload) {
                    if to_steps.send(Raw::Progress(p)).is_err() {
                        break;
                    }
                }
            }
        });
        Ok(SweepCall {
            queue: self,
            id: sweep.to_string(),
            heard,
            forwarders: forward_reports.into_iter().chain(forward_steps).collect(),
            stored: Vec::new(),
        })
    }
}

/// A pulled variant: acknowledged when done (`finish`), given back to run elsewhere
/// (`release`), kept alive meanwhile by in-progress acks (`heartbeat`).
pub struct Delivery<'a> {
    queue: &'a SweepQueue,
    message: jetstream::Message,
    item: WorkItem,
    beat: Option<tokio::task::JoinHandle<()>>,
}

impl Delivery<'_> {
    /// The variant to run.
    pub fn item(&self) -> &WorkItem {
        &self.item
    }

    /// Sends an in-progress ack every [`HEARTBEAT`] until the delivery is settled.
    pub fn heartbeat(&mut self) {
        let m = self.message.clone();
        self.beat = self.queue.spawn(async move {
            loop {
                tokio::time::sleep(HEARTBEAT).await;
                if let Err(e) = m.ack_with(AckKind::Progress).await {
                    tracing::debug!("a sweep variant's in-progress ack failed: {e}");
                }
            }
        });
    }

    /// Done with it: acknowledged, never delivered again (a lost ack only makes a node run it
    /// again, and its result is then unwanted).
    pub fn finish(self) {
        self.settle(AckKind::Ack);
    }

    /// Given back, to be delivered again at once (this node is shutting down, or its result
    /// got no answer).
    pub fn release(self) {
        self.settle(AckKind::Nak(None));
    }

    /// Given back, to be delivered again in a while, preferably to another node (this node
    /// cannot run it: another engine build).
    pub fn decline(self) {
        self.settle(AckKind::Nak(Some(PULL_WAIT)));
    }

    fn settle(mut self, kind: AckKind) {
        self.stop();
        let m = self.message.clone();
        self.queue.cluster.run(async move {
            let _ = m.ack_with(kind).await;
        });
    }

    fn stop(&mut self) {
        if let Some(beat) = self.beat.take() {
            beat.abort();
        }
    }
}

impl Drop for Delivery<'_> {
    fn drop(&mut self) {
        self.stop();
    }
}

/// What the forwarders pass from NATS to the sweeping thread.
enum Raw {
    Progress(Progress),
    Report(Bytes, Option<Subject>),
}

/// What the sweeping node hears from the workers.
pub enum Heard {
    /// A run of variant `.0` has taken `.1` steps.
    Progress(usize, u64),
    /// A run's result, to be answered with [`SweepCall::answer`].
    Report(Box<Report>, Option<Subject>),
}

/// A sweep being run across the nodes, as the sweeping node holds it: its items sent, its
/// progress and results heard until it `end`s.
pub struct SweepCall<'a> {
    queue: &'a SweepQueue,
    id: String,
    heard: mpsc::Receiver<Raw>,
    forwarders: Vec<tokio::task::JoinHandle<()>>,
    /// Objects holding large items and results, deleted at the end.
    stored: Vec<String>,
}

impl SweepCall<'_> {
    /// Puts the sweep's items on the queue. Each has a message id, so sending again after a
    /// failure that may have been partial puts none of them there twice.
    pub fn send(&mut self, items: &[WorkItem]) -> Result<(), String> {
        let mut payloads = Vec::with_capacity(items.len());
        for item in items {
            let (payload, stored) = self.queue.pack(item)?;
            self.stored.extend(stored);
            payloads.push((format!("{}.{}", self.id, item.index), Bytes::from(payload)));
        }
        let (js, subject) = (self.queue.cluster.js.clone(), self.queue.subject("work", &self.id));
        self.queue.cluster.run(async move {
            patiently(|| async {
                let mut acks = Vec::with_capacity(payloads.len());
                for (id, payload) in &payloads {
                    let message = PublishMessage::build().payload(payload.clone()).message_id(id);
                    acks.push(js.send_publish(subject.clone(), message).await.map_err(|e| e.to_string())?);
                }
                for ack in acks {
                    ack.await.map_err(|e| e.to_string())?;
                }
                Ok::<(), String>(())
            })
            .await
        })
    }

    /// What was heard next, waiting at most `wait` (None: nothing usable came).
    pub fn next(&mut self, wait: Duration) -> Option<Heard> {
        let raw = match self.heard.recv_timeout(wait) {
            Ok(raw) => raw,
            Err(mpsc::RecvTimeoutError::Timeout) => return None,
            // The subscriptions ended (the connection closed for good): nothing more will come,
            // and the caller still waits (for a cancellation) without spinning.
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                std::thread::sleep(wait);
                return None;
            }
        };
        match raw {
            Raw::Progress(p) => Some(Heard::Progress(p.index, p.steps)),
            Raw::Report(payload, reply) => match self.queue.unpack::<Report>(&payload) {
                Ok((report, stored)) => {
                    self.stored.extend(stored);
                    Some(Heard::Report(Box::new(report), reply))
                }
                // Unanswered: the worker asks again, then runs the variant again.
                Err(why) => {
                    tracing::warn!("a result of sweep {} could not be read: {}", self.id, why.unwrap_or_else(|| "it does not decode".into()));
                    None
                }
            },
        }
    }

    /// Answers a report: accepted (the first for its variant) or unwanted.
    pub fn answer(&self, reply: Option<Subject>, accepted: bool) {
        let Some(reply) = reply else { return };
        let client = self.queue.client.clone();
        self.queue.spawn(async move {
            let _ = client.publish(reply, if accepted { ACCEPTED } else { UNWANTED }.into()).await;
        });
    }

    /// Ends the sweep on the queue: every node told it is over, its left-over items purged,
    /// the objects it stored deleted; later results find nobody listening.
    pub fn end(mut self) {
        for f in self.forwarders.drain(..) {
            f.abort();
        }
        self.queue.tell_over(&self.id, Vec::new());
        let (js, subject) = (self.queue.cluster.js.clone(), self.queue.subject("work", &self.id));
        let stream = stream_name(&self.queue.cluster.config.namespace);
        self.queue.cluster.run(async move {
            if let Ok(stream) = js.get_stream_no_info(&stream).await {
                if let Err(e) = stream.purge().filter(subject).await {
                    tracing::debug!("purging a sweep's items: {e}");
                }
            }
        });
        self.queue.delete_objects(std::mem::take(&mut self.stored));
    }
}

impl Drop for SweepCall<'_> {
    fn drop(&mut self) {
        for f in self.forwarders.drain(..) {
            f.abort();
        }
    }
}
