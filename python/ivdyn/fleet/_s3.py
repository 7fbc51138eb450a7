"""Logs on object storage: a manifest's ``s3://bucket/key`` is read on the worker that
computes its statistics, downloaded in parts to a temporary file (memory bounded by the
transfer's few chunks, not by the log's size) that the streamed statistics then read, and
removed afterwards.

The client is boto3's, configured the standard AWS way: credentials and region from the
environment (``AWS_ACCESS_KEY_ID``, ``AWS_SECRET_ACCESS_KEY``, ``AWS_SESSION_TOKEN``,
``AWS_DEFAULT_REGION``), ``~/.aws`` or the machine's role, and ``AWS_ENDPOINT_URL`` (or
``AWS_ENDPOINT_URL_S3``) for an S3-compatible server (MinIO, Ceph, a local test server).
On a Ray cluster these must be set where the workers run (the nodes' environment, or
``runtime_env={"env_vars": ...}``).
"""
from __future__ import annotations

import contextlib
import os
import tempfile
import threading
from typing import Any, Callable, Iterator, Tuple, TypeVar

T = TypeVar("T")

#: The URI scheme read here.
SCHEME = "s3://"
#: Parts of a download in flight, and their size: the memory a download may hold.
_CONCURRENCY, _CHUNK = 2, 8 * 1024 * 1024

_lock = threading.Lock()
_client: Any = None


def is_s3(path: str) -> bool:
    return path.startswith(SCHEME)


def split(uri: str) -> Tuple[str, str]:
    """``(bucket, key)`` of ``s3://bucket/key``."""
    bucket, _, key = uri[len(SCHEME):].partition("/")
    if not bucket or not key:
        raise ValueError(f"{uri}: an S3 log is named s3://bucket/key")
    return bucket, key


def _s3_client(uri: str) -> Any:
    """One client per process (boto3's clients are thread-safe, its sessions are not)."""
    global _client
    with _lock:
        if _client is None:
            try:
                import boto3  # type: ignore[import-untyped,import-not-found]
            except ImportError as e:
                raise ImportError(f"{uri}: reading s3:// logs needs boto3 (pip install 'ivdyn[s3]')") from e
            _client = boto3.session.Session().client("s3")
        return _client


@contextlib.contextmanager
def local_copy(uri: str) -> Iterator[str]:
    """A temporary local copy of the object ``uri`` (with the key's extension, which
    tells MCAP from CSV), removed on exit. Errors name the URI."""
    bucket, key = split(uri)
    client = _s3_client(uri)
    from boto3.s3.transfer import TransferConfig  # type: ignore[import-untyped,import-not-found]

    fd, path = tempfile.mkstemp(prefix="ivdyn-s3-", suffix=os.path.splitext(key)[1])
    os.close(fd)
    try:
        try:
            cfg = TransferConfig(max_concurrency=_CONCURRENCY, multipart_chunksize=_CHUNK)
            client.download_file(bucket, key, path, Config=cfg)
        except Exception as e:  # noqa: BLE001 -- botocore's errors name neither the bucket nor the key
            raise OSError(f"{uri}: cannot read the log from S3: {e}") from e
        yield path
    finally:
        os.unlink(path)


def named(uri: str, path: str, work: Callable[[], T]) -> T:
    """``work()``, its errors naming ``uri`` instead of the temporary copy ``path``."""
    try:
        return work()
    except Exception as e:  # noqa: BLE001 -- re-raised, renamed
        msg = str(e).replace(path, uri)
        try:
            renamed = type(e)(msg)
        except Exception:  # noqa: BLE001 -- an exception type that takes other arguments
            renamed = RuntimeError(msg)
        raise renamed from e
