//! `derma view`: a small static HTTP/1.1 server on localhost for the built web viewer (at /)
//! and a directory from `derma export web` (at /data/), one thread per connection.

use crate::error::Result;
use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Component, Path, PathBuf};

/// The viewer built in this source tree (`npm --prefix viewer run build` → viewer/dist).
pub fn default_viewer_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../viewer/dist")
}

/// A bound server.
pub struct Server {
    listener: TcpListener,
    viewer: PathBuf,
    data: PathBuf,
}

fn content_type(p: &Path) -> &'static str {
    match p.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript",
        "css" => "text/css",
        "json" => "application/json",
        "png" => "image/png",
        "glb" => "model/gltf-binary",
        "exr" => "image/x-exr",
        "svg" => "image/svg+xml",
        _ => "application/octet-stream",
    }
}

/// `rel` under `root`, or None when it would leave it.
fn resolve(root: &Path, rel: &str) -> Option<PathBuf> {
    let rel = rel.split(['?', '#']).next().unwrap_or("");
    let p = Path::new(rel.trim_start_matches('/'));
    if p.components().any(|c| !matches!(c, Component::Normal(_))) {
        return None;
    }
    Some(root.join(p))
}

impl Server {
    /// Binds 127.0.0.1:`port` (0: any free port).
    pub fn bind(viewer: &Path, data: &Path, port: u16) -> Result<Server> {
        let listener = TcpListener::bind(("127.0.0.1", port))?;
        Ok(Server {
            listener,
            viewer: viewer.to_path_buf(),
            data: data.to_path_buf(),
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.listener.local_addr().expect("bound")
    }

    /// Serves until the process ends.
    pub fn run(&self) -> Result<()> {
        for stream in self.listener.incoming() {
            let Ok(stream) = stream else { continue };
            let (viewer, data) = (self.viewer.clone(), self.data.clone());
            std::thread::spawn(move || {
                let _ = handle(stream, &viewer, &data);
            });
        }
        Ok(())
    }
}

fn handle(mut stream: TcpStream, viewer: &Path, data: &Path) -> std::io::Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    // Drain the headers.
    let mut h = String::new();
    while reader.read_line(&mut h)? > 2 {
        h.clear();
    }
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
    let file = if let Some(rest) = target.strip_prefix("/data/") {
        resolve(data, rest)
    } else if target == "/" || target.starts_with("/?") {
        Some(viewer.join("index.html"))
    } else {
        resolve(viewer, target)
    };
    let body = file
        .as_ref()
        .filter(|p| p.is_file())
        .and_then(|p| std::fs::read(p).ok());
    match (method, body) {
        ("GET" | "HEAD", Some(b)) => {
            let ct = content_type(file.as_deref().expect("file"));
            write!(
                stream,
                "HTTP/1.1 200 OK\r\nContent-Type: {ct}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
                b.len()
            )?;
            if method == "GET" {
                stream.write_all(&b)?;
            }
        }
        _ => {
            let msg = b"not found";
            write!(
                stream,
                "HTTP/1.1 404 Not Found\r\nContent-Type: text/plain\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
                msg.len()
            )?;
            stream.write_all(msg)?;
        }
    }
    stream.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_cannot_leave_the_served_directories() {
        let root = Path::new("/srv");
        assert_eq!(
            resolve(root, "/a/b.png"),
            Some(PathBuf::from("/srv/a/b.png"))
        );
        assert_eq!(
            resolve(root, "/a.json?x=1"),
            Some(PathBuf::from("/srv/a.json"))
        );
        assert_eq!(resolve(root, "/../etc/passwd"), None);
        assert_eq!(resolve(root, "/a/../../b"), None);
    }
}
