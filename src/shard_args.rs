//! `--shard` and `--shards`: the arguments of a sharded command, resolved
//! by [`fxshade_flows::shard`].

use fxshade_flows::shard::{parse_arg, resolve, Shard, ShardArg};

/// `--shard` and `--shards`, as every sharded command takes them.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ShardArgs {
    /// Take only shard K of N (0-based): a deterministic, disjoint slice;
    /// `auto` reads it from the job array that started this process
    /// (Slurm, LSF, Grid Engine, a Kubernetes Indexed Job) or from
    /// `FXSHADE_SHARD=K/N`.
    #[arg(long, value_name = "K/N|auto", value_parser = parse_arg)]
    pub shard: Option<ShardArg>,
    /// With `--shard auto`: the run has N shards, numbered from the task
    /// ids (task = the scheduler's first index + K) whatever the array
    /// holds; needed by a Kubernetes Indexed Job (its `completions`) and by
    /// a resubmitted subset of an array. `FXSHADE_SHARDS=N` says the same.
    #[arg(long, value_name = "N", requires = "shard")]
    pub shards: Option<usize>,
}

impl ShardArgs {
    /// The shard this process takes, or `None` without `--shard`; a usage
    /// error (exit status 2) names what is wrong.
    pub fn resolve(&self) -> Result<Option<Shard>, crate::output::UsageError> {
        if self.shards.is_some() && !matches!(self.shard, Some(ShardArg::Auto)) {
            return Err(crate::output::UsageError(
                "--shards N goes with --shard auto".into(),
            ));
        }
        resolve(self.shard.as_ref(), self.shards).map_err(crate::output::UsageError)
    }
}
