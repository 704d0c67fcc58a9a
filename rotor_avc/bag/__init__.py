"""Bags: single ``.mcap`` files in the rosbag2 MCAP profile, read and written without ROS.

``ros2 bag info/play``, Foxglove, the ``mcap`` package (with ``mcap-ros2-support``) and the
``rosbags`` library read them (DESIGN.md section 5). Modules:

* :mod:`.topics` -- the recorded topics and message types, and time series -> :class:`Stream`;
* :mod:`.writer` -- :class:`BagWriter` (raw CDR, dict messages, vectorised streams),
  :func:`write_bag`;
* :mod:`.reader` -- :class:`BagReader`: topics, counts, time range, metadata, configuration,
  messages, numpy series;
* :mod:`.recover` -- :func:`recover_bag` finishes a recording that was killed;
* :mod:`.msgdefs`, :mod:`.cdr`, :mod:`.mcap_writer`, :mod:`.metadata` -- the format's parts.
"""
from .errors import BagError
from .reader import BagReader, TopicSeries
from .recover import recover_bag
from .topics import Stream
from .writer import BagWriter, write_bag

__all__ = ["BagError", "BagReader", "BagWriter", "Stream", "TopicSeries", "recover_bag",
           "write_bag"]
