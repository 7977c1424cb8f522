//
// PATCHED (cellsar): this module is not in the published crate.
//
// SPDX-License-Identifier: EPL-2.0 OR Apache-2.0
//
//! A TLS stream shared by a link's reading and writing tasks, locked for one poll at a time.
//!
//! The published crate kept the stream in an `UnsafeCell` and let both tasks take `&mut` to it
//! at once. A rustls connection is one state machine for both directions and allows no
//! concurrent use (rustls#288): under traffic both ways the tasks raced on it and the process
//! crashed (zenoh#2557). Here every poll of either direction holds a mutex for that poll only,
//! never across an `.await`, as `tokio::io::split` does (the way tokio-rustls supports reading
//! and writing one stream from two tasks).

use std::{
    future::poll_fn,
    io,
    pin::Pin,
    sync::{Mutex, MutexGuard},
};

use tokio::{
    io::{AsyncRead, AsyncWrite, ReadBuf},
    net::TcpStream,
};
use tokio_rustls::TlsStream;

pub(crate) struct LockedStream(Mutex<TlsStream<TcpStream>>);

impl LockedStream {
    pub(crate) fn new(stream: TlsStream<TcpStream>) -> Self {
        Self(Mutex::new(stream))
    }

    // a poisoned lock still holds a stream, which a later poll reports errors on
    fn lock(&self) -> MutexGuard<'_, TlsStream<TcpStream>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The stream, without locking (only its owner can call this).
    pub(crate) fn get_mut(&mut self) -> &mut TlsStream<TcpStream> {
        self.0.get_mut().unwrap_or_else(|e| e.into_inner())
    }

    /// One read of at most `buf.len()` bytes.
    pub(crate) async fn read(&self, buf: &mut [u8]) -> io::Result<usize> {
        let mut buf = ReadBuf::new(buf);
        poll_fn(|cx| Pin::new(&mut *self.lock()).poll_read(cx, &mut buf)).await?;
        Ok(buf.filled().len())
    }

    /// Reads until `buf` is full (an end of stream first: `UnexpectedEof`, as tokio's).
    pub(crate) async fn read_exact(&self, buf: &mut [u8]) -> io::Result<()> {
        let mut filled = 0;
        while filled < buf.len() {
            match self.read(&mut buf[filled..]).await? {
                0 => return Err(io::ErrorKind::UnexpectedEof.into()),
                n => filled += n,
            }
        }
        Ok(())
    }

    /// One write of at most `buf.len()` bytes.
    pub(crate) async fn write(&self, buf: &[u8]) -> io::Result<usize> {
        poll_fn(|cx| Pin::new(&mut *self.lock()).poll_write(cx, buf)).await
    }

    /// Writes all of `buf` (a zero write: `WriteZero`, as tokio's).
    pub(crate) async fn write_all(&self, mut buf: &[u8]) -> io::Result<()> {
        while !buf.is_empty() {
            match self.write(buf).await? {
                0 => return Err(io::ErrorKind::WriteZero.into()),
                n => buf = &buf[n..],
            }
        }
        Ok(())
    }

    /// Flushes the TLS stream.
    pub(crate) async fn flush(&self) -> io::Result<()> {
        poll_fn(|cx| Pin::new(&mut *self.lock()).poll_flush(cx)).await
    }

    /// Shuts the underlying TCP stream down.
    pub(crate) async fn shutdown_tcp(&self) -> io::Result<()> {
        poll_fn(|cx| Pin::new(&mut self.lock().get_mut().0).poll_shutdown(cx)).await
    }
}
