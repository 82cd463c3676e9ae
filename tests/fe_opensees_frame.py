"""The OpenSees route's fixture: the frame's builder (`vibupdate.examples.frame3d_opensees`)."""

from vibupdate.examples.frame3d import BEAM_WIDTH  # noqa: F401
from vibupdate.examples.frame3d_opensees import build_frame  # noqa: F401
