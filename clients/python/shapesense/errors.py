"""The one exception type of the shapesense client."""

from __future__ import annotations

from typing import Optional

import grpc


class ShapeSenseError(Exception):
    """A call the daemon answered with an error, or one that never reached it.

    ``code`` is the gRPC status code's name (``"INVALID_ARGUMENT"``, ``"OUT_OF_RANGE"``,
    ``"UNAVAILABLE"``, ...), ``message`` the daemon's own words (what to change), ``status`` the
    ``grpc.StatusCode``. ``str(error)`` reads as the CLI prints it: ``CODE: message``.
    """

    def __init__(self, code: str, message: str, status: Optional[grpc.StatusCode] = None):
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message
        self.status = status

    @classmethod
    def from_rpc_error(cls, error: grpc.RpcError) -> "ShapeSenseError":
        """The error a failed gRPC call raised, as a ShapeSenseError."""
        status = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
        details = error.details() if hasattr(error, "details") else str(error)
        return cls(status.name, details or "", status)
