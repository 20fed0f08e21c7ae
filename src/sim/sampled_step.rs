//! A step with samples or measures — step_simulation's `sample_every`/`sample_objects`/
//! `measure` and run_sweep's `observe.every` — taken through the one apply path with a
//! `Sampler` watching: the event and its hash are a plain step's, its `measure` part of its
//! command and its answers of its recorded result (`fold::apply`); the samples (the interval
//! sampling rule, `fold::Cadence`) go to the reply only. Bounds are checked before stepping,
//! since a step cannot be refused after it is taken.

use crate::command::Command;
use crate::limits::Limits;
use crate::log::fold;
use crate::outputs::Stepped;
use crate::seeing::measure::{self, Spec};
use crate::seeing::trajectory::{self, Request};
use crate::sim::Sim;
use crate::value::{Args, Refusal};
use crate::world::{StepControl, World};

/// What to sample while stepping.
#[derive(Clone, Debug, Default)]
pub struct Sampling {
    /// Steps between samples (None: about 100 samples over the step).
    pub every: Option<u64>,
    /// The objects sampled (None: all).
    pub object_ids: Option<Vec<u32>>,
    /// Velocities too.
    pub include_velocities: bool,
    /// The samples as a model reads them by default (`trajectory::compact` at these decimals),
    /// None for the exact form (`detail: "full"`).
    pub compact: Option<u32>,
    /// Whether samples are asked for (false: only `measure`).
    pub samples: bool,
    /// Measures taken after every step (`seeing::measure`): part of the step's command, so its
    /// recorded result holds their exact answers (the reply rounds them like the samples).
    pub measure: Vec<Spec>,
    /// The sample columns to keep (`trajectory::select`), None for all.
    pub fields: Option<Vec<String>>,
}

impl Sim {
    /// Takes `steps` steps sampling as `sampling` says; `args` are the call's arguments as
    /// the log records them. A refusal (an unknown object, too many samples, a reply over the
    /// budget) is logged and changes nothing.
    pub fn step_sampled(&mut self, args: &Args, steps: u64, sampling: &Sampling, limits: &Limits, control: StepControl) -> Result<Stepped, Refusal> {
        self.step_sampled_watched(args, steps, sampling, limits, control, &mut |_| {})
    }

    /// `step_sampled` with `watch` seeing the world after every step too (a sweep's peak
    /// speeds), without changing what is sampled or logged.
    pub fn step_sampled_watched(
        &mut self,
        args: &Args,
        steps: u64,
        sampling: &Sampling,
        limits: &Limits,
        control: StepControl,
        watch: crate::world::StepObserver,
    ) -> Result<Stepped, Refusal> {
        let every = match self.check_sampling(steps, sampling, limits) {
            Ok(every) => every,
            Err(why) => return Err(self.refuse("step_simulation", args, why)),
        };
        let (from, seq) = (self.log().head_seq(), self.log().next_seq());
        let req = Request { every: Some(every), object_ids: sampling.object_ids.clone(), include_velocities: sampling.include_velocities };
        let mut sampler = trajectory::Sampler::new(fold::Interval { from_seq: from, to_seq: seq }, every, &req);
        if sampling.samples {
            sampler.sample(self.world(), from);
        }
        let mut cadence = fold::Cadence::new(every);
        let mut observe = |w: &World| {
            watch(w);
            if cadence.step() && sampling.samples {
                sampler.sample(w, seq);
            }
        };
        let measure = (!sampling.measure.is_empty()).then(|| sampling.measure.clone());
        let outcome = self.change_observed("step_simulation", args, Ok(Command::StepSimulation { steps, measure }), limits, control, &mut observe)?;
        let mut result = Stepped::try_from(outcome).map_err(|_| "Internal error: step_simulation gave a result of an unexpected kind".to_string())?;
        if cadence.end() && sampling.samples {
            sampler.sample(self.world(), seq);
        }
        // The samples' seq is the event's, appended right after `head_seq`.
        debug_assert_eq!(self.log().head_seq(), seq);
        if sampling.samples {
            result.trajectory = sampler.finish("sample_every").ok();
        }
        if let (Some(t), Some(f)) = (result.trajectory.as_mut(), &sampling.fields) {
            trajectory::select(t, f);
        }
        if let (Some(t), Some(decimals)) = (result.trajectory.as_mut(), sampling.compact) {
            trajectory::compact(t, Some(decimals));
        }
        if let (Some(m), Some(decimals)) = (result.measures.as_mut(), sampling.compact) {
            m.iter_mut().for_each(|m| measure::round(m, decimals));
        }
        Ok(result)
    }

    /// The steps between samples, or why the sampling cannot be done: an object that does not
    /// exist, too many samples, or samples whose documented size could not fit the reply.
    fn check_sampling(&self, steps: u64, sampling: &Sampling, limits: &Limits) -> Result<u64, Refusal> {
        let w = self.world();
        measure::check_objects("measure", &sampling.measure, |id| w.has_object(id))?;
        if !sampling.samples {
            return Ok(steps.max(1));
        }
        let listed: Vec<u32> = sampling.object_ids.clone().unwrap_or_else(|| w.objects().map(|(id, _)| id).collect());
        if let Some(id) = listed.iter().find(|id| !w.has_object(**id)) {
            return Err(format!("sample_objects: object {id} does not exist in simulation {}", w.simulation_id()));
        }
        let every = sampling.every.unwrap_or_else(|| trajectory::default_every(steps));
        let samples = trajectory::max_samples(steps, every);
        trajectory::check_cells(samples, listed.len() as u64, "sample_every")?;
        let numbers = listed.iter().map(|id| trajectory::numbers_per_object(w, *id, sampling.include_velocities)).sum();
        crate::sim::budget::check_structured_bound("step_simulation", trajectory::reply_bound(samples, numbers), limits.max_reply_bytes)?;
        Ok(every)
    }
}
