"""The responses of a closed loop through one interface, whether it is the continuous loop
(:class:`~rotor_avc.closed_loop.loop.ClosedLoop`, the papers' FRFs) or the sampled one
(:class:`~rotor_avc.analysis.sampled_loop.SampledLoop`, what a lockstep run reproduces), so
that a caller comparing the two, or using either, does not branch on the kind:

* :func:`unbalance_response` -- the synchronous response to the excitations over speed
  (:func:`rotor_avc.closed_loop.frf.unbalance_frf`, :meth:`SampledLoop.unbalance_frf`);
* :func:`force_response` -- the response to a force at one actuator over frequency at one speed
  (:func:`rotor_avc.analysis.transfer.transfer_frf`,
  :func:`rotor_avc.analysis.transfer.sampled_transfer_frf`).
"""
from __future__ import annotations

from functools import singledispatch

from ..closed_loop.frf import SpeedFrf, unbalance_frf
from ..closed_loop.loop import ClosedLoop
from .sampled_loop import SampledLoop
from .transfer import TransferFrf, sampled_transfer_frf, transfer_frf


@singledispatch
def unbalance_response(loop, speed_rad_s, excitations=None, w_F=None) -> SpeedFrf:
    """Synchronous responses of every output and actuator force to each excitation."""
    raise TypeError(f"no unbalance response of a {type(loop).__name__}")


@unbalance_response.register
def _(loop: ClosedLoop, speed_rad_s, excitations=None, w_F=None) -> SpeedFrf:
    return unbalance_frf(loop, speed_rad_s, excitations, w_F)


@unbalance_response.register
def _(loop: SampledLoop, speed_rad_s, excitations=None, w_F=None) -> SpeedFrf:
    return loop.unbalance_frf(speed_rad_s, excitations, w_F)


@singledispatch
def force_response(loop, speed_rad_s: float, freq_hz, input_id: str, outputs=None,
                   w_F=None) -> TransferFrf:
    """Responses per unit force at actuator ``input_id`` over ``freq_hz`` at one speed."""
    raise TypeError(f"no force response of a {type(loop).__name__}")


@force_response.register
def _(loop: ClosedLoop, speed_rad_s: float, freq_hz, input_id: str, outputs=None,
      w_F=None) -> TransferFrf:
    return transfer_frf(loop, speed_rad_s, freq_hz, input_id, outputs, w_F)


@force_response.register
def _(loop: SampledLoop, speed_rad_s: float, freq_hz, input_id: str, outputs=None,
      w_F=None) -> TransferFrf:
    return sampled_transfer_frf(loop, speed_rad_s, freq_hz, input_id, outputs, w_F)
