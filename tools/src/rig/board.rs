//! The emulated robot controller: the example firmware (`board/firmware`, feature
//! `mps2-an386`) in `qemu-system-arm -M mps2-an386`, its two UARTs on pseudo-terminals.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use serialport::TTYPort;

/// How long qemu may take to start and name its pseudo-terminals.
const START_TIMEOUT: Duration = Duration::from_secs(20);
/// How long the firmware may take to answer the mode line (qemu's pty backend notices a
/// reader about once a second).
const READY_TIMEOUT: Duration = Duration::from_secs(10);
/// Nominal baud of the ports (a pseudo-terminal ignores it).
const PTY_BAUD: u32 = 115_200;
/// The board's scheduling priority (`nice -n`; negative is higher).
const BOARD_NICENESS: &str = "-10";
/// Read timeout of the board's ports.
const PORT_TIMEOUT: Duration = Duration::from_millis(50);

/// The running board.
pub struct Board {
    qemu: Child,
    /// UART0: glint's frames in.
    pub uart0: TTYPort,
    /// UART1: the rig's lines in and out.
    pub uart1: TTYPort,
}

impl Board {
    /// Starts `qemu` (the binary) with `elf`, and sets the firmware's compensation.
    pub fn start(qemu: &Path, elf: &Path, compensate: bool) -> Result<Board> {
        // The board runs at a higher priority than the rest of the machine (coreutils'
        // `nice`; without the right to raise it, `nice` says so and runs qemu as it is): a
        // real robot's controller has a processor of its own, and an emulator scheduled late
        // on a busy host hands the firmware its bytes late, an age error no real UART makes.
        let mut child = Command::new("nice")
            .args(["-n", BOARD_NICENESS])
            .arg(qemu)
            .args(["-M", "mps2-an386", "-display", "none", "-monitor", "none"])
            .args(["-serial", "pty", "-serial", "pty", "-kernel"])
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .with_context(|| format!("cannot start {}", qemu.display()))?;
        let stdout = child.stdout.take().context("qemu's standard output")?;
        let (tx, rx) = mpsc::channel();
        // qemu names each pty on standard output: "char device redirected to /dev/pts/N (label
        // serial0)"; the rest of its output is passed on to standard error.
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                match line.split_whitespace().find(|w| w.starts_with("/dev/pts/")) {
                    Some(path) => {
                        let _ = tx.send(path.to_owned());
                    }
                    None => eprintln!("qemu: {line}"),
                }
            }
        });
        let mut ptys = Vec::new();
        let deadline = Instant::now() + START_TIMEOUT;
        while ptys.len() < 2 {
            let left = deadline.saturating_duration_since(Instant::now());
            match rx.recv_timeout(left) {
                Ok(path) => ptys.push(path),
                Err(_) => {
                    let _ = child.kill();
                    bail!("qemu did not name two pseudo-terminals within {START_TIMEOUT:?}");
                }
            }
        }
        let open = |path: &str| {
            serialport::new(path, PTY_BAUD)
                .timeout(PORT_TIMEOUT)
                .open_native()
                .with_context(|| format!("cannot open the board's UART at {path}"))
        };
        let mut board = Board {
            uart0: open(&ptys[0])?,
            uart1: open(&ptys[1])?,
            qemu: child,
        };
        board.set_mode(compensate)?;
        Ok(board)
    }

    /// Sends the mode line and waits for the firmware's `ready`.
    fn set_mode(&mut self, compensate: bool) -> Result<()> {
        let mode = if compensate { "on" } else { "off" };
        let expected = format!("ready compensate={}", u8::from(compensate));
        std::io::Write::write_all(&mut self.uart1, format!("compensate {mode}\n").as_bytes())?;
        let deadline = Instant::now() + READY_TIMEOUT;
        let mut seen = Vec::new();
        // A byte at a time: what follows the answer (the LED's first line) is the reader's.
        let mut buf = [0u8; 1];
        while Instant::now() < deadline {
            match self.uart1.read(&mut buf) {
                Ok(n) => seen.extend_from_slice(buf.get(..n).unwrap_or(&[])),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => return Err(e).context("reading the board's UART1"),
            }
            if seen.ends_with(b"\n")
                && String::from_utf8_lossy(&seen)
                    .lines()
                    .any(|l| l.trim() == expected)
            {
                return Ok(());
            }
        }
        bail!(
            "the firmware did not answer `compensate {mode}` within {READY_TIMEOUT:?} (it said {:?})",
            String::from_utf8_lossy(&seen)
        )
    }

    /// The board's UART1 for the rig's reader, a second handle on the same port.
    pub fn uart1_reader(&self) -> Result<TTYPort> {
        self.uart1.try_clone_native().context("cloning UART1")
    }
}

impl Drop for Board {
    fn drop(&mut self) {
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
    }
}
