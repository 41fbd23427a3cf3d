//! `--publish KEY` and its options: every report over Zenoh (src/net). Without the `net`
//! feature the options still parse, and asking to publish says the build cannot.

#[cfg(feature = "net")]
use anyhow::Result;
use clap::Args;

/// Where a host name is read for the default camera name.
#[cfg(feature = "net")]
const HOSTNAME_PATH: &str = "/proc/sys/kernel/hostname";

/// The camera name when the host has none that fits a key.
#[cfg(feature = "net")]
const FALLBACK_CAMERA_NAME: &str = "glint";

/// The ROS 2 domain ids rmw_zenoh accepts.
const MAX_ROS_DOMAIN_ID: u32 = 232;

/// Options of network publishing.
#[derive(Debug, Args)]
pub struct PublishArgs {
    /// Publish every report over Zenoh (peer to peer, no router needed) under KEY/CAMERA: as
    /// JSON lines, in binary under KEY/CAMERA/bin, and floor positions as ROS 2 PointStamped
    /// (README: "Publishing on the network"). Without --zenoh-connect or --zenoh-listen, Zenoh
    /// finds its peers by multicast scouting and listens on a free TCP port.
    #[arg(long, value_name = "KEY")]
    pub publish: Option<String>,

    /// With --publish: this camera's name in the keys and the reports (letters, digits, '_',
    /// '-', '.'); the host name by default.
    #[arg(long, value_name = "NAME", requires = "publish")]
    camera_name: Option<String>,

    /// With --publish: connect to this Zenoh endpoint (`tcp/HOST:PORT`), and reconnect when it
    /// comes back; repeatable. Any endpoint turns multicast scouting off.
    #[arg(long, value_name = "ENDPOINT", requires = "publish")]
    zenoh_connect: Vec<String>,

    /// With --publish: listen on this Zenoh endpoint (`tcp/ADDR:PORT`); repeatable. Any
    /// endpoint turns multicast scouting off.
    #[arg(long, value_name = "ENDPOINT", requires = "publish")]
    zenoh_listen: Vec<String>,

    /// With --publish: the ROS 2 domain id in the rmw_zenoh key (default: $ROS_DOMAIN_ID, or 0).
    #[arg(long, value_name = "ID", requires = "publish",
          value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_ROS_DOMAIN_ID)))]
    ros_domain_id: Option<u32>,
}

#[cfg(feature = "net")]
impl PublishArgs {
    /// The camera name: given, or the host name.
    fn camera_name(&self) -> String {
        if let Some(name) = &self.camera_name {
            return name.clone();
        }
        std::fs::read_to_string(HOSTNAME_PATH)
            .map(|h| h.trim().to_owned())
            .ok()
            .filter(|h| !h.is_empty())
            .unwrap_or_else(|| FALLBACK_CAMERA_NAME.to_owned())
    }

    /// The ROS domain id: given, or $ROS_DOMAIN_ID when it is one, or 0.
    fn ros_domain_id(&self) -> Result<u32> {
        if let Some(id) = self.ros_domain_id {
            return Ok(id);
        }
        match std::env::var("ROS_DOMAIN_ID") {
            Ok(text) if !text.trim().is_empty() => match text.trim().parse::<u32>() {
                Ok(id) if id <= MAX_ROS_DOMAIN_ID => Ok(id),
                _ => anyhow::bail!(
                    "ROS_DOMAIN_ID={text:?} is not a domain id from 0 to {MAX_ROS_DOMAIN_ID}"
                ),
            },
            _ => Ok(0),
        }
    }
}

#[cfg(feature = "net")]
mod enabled {
    use anyhow::{Context, Result};
    use glint::budget::MemoryPlan;
    use glint::net::{self, KeyError, Keys, PublishConfig};

    use super::PublishArgs;

    /// The sink that publishes.
    pub type PublishSink = net::PublishSink;

    /// Starts publishing when `--publish` asks.
    pub fn open(args: &PublishArgs) -> Result<Option<PublishSink>> {
        let Some(key) = args.publish.as_deref() else {
            return Ok(None);
        };
        let camera = args.camera_name();
        let keys = Keys::new(key, &camera, args.ros_domain_id()?).map_err(|e| match e {
            KeyError::BadCameraName(_) if args.camera_name.is_none() => {
                anyhow::anyhow!("--publish {key}: the host name as {e}: give --camera-name")
            }
            _ => anyhow::anyhow!("--publish {key}: {e}"),
        })?;
        let config = PublishConfig {
            keys,
            connect: args.zenoh_connect.clone(),
            listen: args.zenoh_listen.clone(),
        };
        let sink = PublishSink::start(&config).with_context(|| format!("--publish {key}"))?;
        log::info!("publishing under {} (camera {camera})", config.keys.json);
        Ok(Some(sink))
    }

    /// Adds the publish queue to the memory plan.
    pub fn plan(args: &PublishArgs, plan: &mut MemoryPlan) {
        if args.publish.is_some() {
            plan.add(
                "the publish queue",
                "--publish".into(),
                net::QUEUE_BYTES as u64,
            );
        }
    }
}

#[cfg(not(feature = "net"))]
mod enabled {
    use core::fmt;
    use std::io;

    use anyhow::{bail, Result};
    use glint::budget::MemoryPlan;
    use glint::report::FrameReport;
    use glint::sink::Sink;

    use super::PublishArgs;

    /// No sink publishes in a build without the network: none can be made.
    pub enum PublishSink {}

    impl Sink for PublishSink {
        fn write(&mut self, _report: &FrameReport) -> io::Result<()> {
            match *self {}
        }

        fn finish(&mut self) -> io::Result<()> {
            match *self {}
        }

        fn status(&self, _out: &mut fmt::Formatter<'_>) -> fmt::Result {
            match *self {}
        }
    }

    /// Refuses `--publish`: this build has no network.
    pub fn open(args: &PublishArgs) -> Result<Option<PublishSink>> {
        if args.publish.is_some() {
            bail!("--publish: this glint was built without the `net` feature");
        }
        Ok(None)
    }

    /// Nothing to plan.
    pub fn plan(_args: &PublishArgs, _plan: &mut MemoryPlan) {}
}

pub use enabled::{open, plan, PublishSink};
