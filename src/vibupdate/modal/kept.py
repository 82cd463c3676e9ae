"""Results kept for re-use within a run, keyed by the content of the matrices they came from.

One run asks for the same modal results in several stages (the polish's last evaluation, the
verification, the sensitivity rows, the linearized ranges, the damping checks, the plots),
each with its own copy of the matrices. `content_key` names matrices by their values, and a
`Kept` store holds the most recent results under a count and a byte bound, behind a lock (one
store may serve several threads).
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np
import scipy.sparse as sp


def content_key(*matrices, extra: bytes = b"") -> str:
    """A hash of the values of ``matrices`` (dense or sparse, any storage order, explicit zeros
    ignored), and of ``extra``. The inputs are not modified."""
    h = hashlib.blake2b(digest_size=20)
    for A in matrices:
        A = sp.csr_matrix(A, dtype=float, copy=True)
        A.eliminate_zeros()
        A.sum_duplicates()           # canonical: sorted indices, no duplicates
        h.update(np.asarray(A.shape, dtype=np.int64).tobytes())
        for part in (A.indptr.astype(np.int64), A.indices.astype(np.int64), A.data):
            h.update(np.ascontiguousarray(part).tobytes())
        h.update(b"|")
    h.update(extra)
    return h.hexdigest()


class Kept:
    """The most recent results: at most ``count`` of them and ``nbytes`` bytes (the newest is
    always kept). Values are stored as given; callers hand out copies."""

    def __init__(self, count: int, nbytes: int):
        self.count, self.nbytes = count, nbytes
        self._items: OrderedDict = OrderedDict()
        self._sizes: dict = {}
        self._total = 0            # sum of ``_sizes``, kept as they change
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._items)

    def get(self, key):
        """The value kept under ``key`` (now the most recent), or None."""
        with self._lock:
            if key not in self._items:
                return None
            self._items.move_to_end(key)
            return self._items[key]

    def put(self, key, value, nbytes: int) -> None:
        """Keep ``value`` (of ``nbytes`` bytes) under ``key``, dropping the oldest beyond the bounds."""
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            self._total += int(nbytes) - self._sizes.get(key, 0)
            self._sizes[key] = int(nbytes)
            while len(self._items) > 1 and (len(self._items) > self.count or self._total > self.nbytes):
                old, _ = self._items.popitem(last=False)
                self._total -= self._sizes.pop(old)
