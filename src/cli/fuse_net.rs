//! `glint fuse`'s network: one Zenoh session for `--subscribe` and `--publish` together (so one
//! `--zenoh-listen` endpoint serves both), and the fused steps' publisher
//! (`glint::net::fused`). Without the `net` feature the options still parse, and asking for the
//! network says the build cannot.

#[cfg(feature = "net")]
mod enabled {
    use anyhow::{Context, Result};
    use zenoh::Wait;

    use glint::fuse::FusedStep;
    use glint::net::fused::{fused_keys, FusedPublisher};
    use glint::net::open_session;

    use super::super::fuse::FuseArgs;

    /// The session shared by the subscription and the publisher.
    pub struct Network {
        pub session: zenoh::Session,
    }

    /// The fused steps' publisher.
    pub type Publisher = FusedPublisher;

    /// Opens the session when `--subscribe` or `--publish` asks for one.
    pub fn open(args: &FuseArgs) -> Result<Option<Network>> {
        if args.subscribe.is_none() && args.publish.is_none() {
            return Ok(None);
        }
        let session = open_session(&args.zenoh_connect, &args.zenoh_listen)
            .context("glint fuse's zenoh session")?;
        Ok(Some(Network { session }))
    }

    /// Starts publishing the fused steps under `--publish KEY`, on the session.
    pub fn publisher(args: &FuseArgs, network: Option<&Network>) -> Result<Option<Publisher>> {
        let (Some(key), Some(network)) = (args.publish.as_deref(), network) else {
            return Ok(None);
        };
        let (json_key, _) = fused_keys(key).map_err(|e| anyhow::anyhow!("--publish {key}: {e}"))?;
        let publisher = FusedPublisher::start(&network.session, key)
            .with_context(|| format!("--publish {key}"))?;
        log::info!("publishing the fused steps under {json_key}");
        Ok(Some(publisher))
    }

    /// Queues one step (its JSON line and the step).
    pub fn publish(publisher: &mut Publisher, line: &[u8], step: &FusedStep) {
        publisher.publish(line, step);
    }

    /// Sends what is queued, and says what publishing did.
    pub fn finish(publisher: &mut Publisher) {
        publisher.finish();
        super::super::logger::write_line(format_args!(
            "glint: fuse: publish: {}",
            publisher.stats()
        ));
    }

    /// Closes the session, once the subscription and the publisher are done.
    pub fn close(network: Network) {
        if let Err(e) = network.session.close().wait() {
            log::warn!("fuse: closing the zenoh session: {e}");
        }
    }
}

#[cfg(not(feature = "net"))]
mod enabled {
    use anyhow::{bail, Result};

    use glint::fuse::FusedStep;

    use super::super::fuse::FuseArgs;

    /// No session in a build without the network: none can be made.
    pub enum Network {}

    /// No publisher either.
    pub enum Publisher {}

    /// Refuses `--subscribe` and `--publish`: this build has no network.
    pub fn open(args: &FuseArgs) -> Result<Option<Network>> {
        if args.subscribe.is_some() || args.publish.is_some() {
            bail!("--subscribe and --publish: this glint was built without the `net` feature");
        }
        Ok(None)
    }

    pub fn publisher(_args: &FuseArgs, network: Option<&Network>) -> Result<Option<Publisher>> {
        match network {
            None => Ok(None),
            Some(n) => match *n {},
        }
    }

    pub fn publish(publisher: &mut Publisher, _line: &[u8], _step: &FusedStep) {
        match *publisher {}
    }

    pub fn finish(publisher: &mut Publisher) {
        match *publisher {}
    }

    pub fn close(network: Network) {
        match network {}
    }
}

pub use enabled::{close, finish, open, publish, publisher, Network, Publisher};
