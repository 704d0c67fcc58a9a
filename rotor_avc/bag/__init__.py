"""Bags: single ``.mcap`` files in the rosbag2 MCAP profile, read and written without ROS.

``ros2 bag info/play``, Foxglove, the ``mcap`` package (with ``mcap-ros2-support``) and the
``rosbags`` library read them (DESIGN.md section 5). Modules:

* :mod:`.topics` -- the recorded topics and message types, and time series -> :class:`Stream`;
* :mod:`.writer` -- :class:`BagWriter` (raw CDR, dict messages, vectorised streams),
  :func:`write_bag`;
* :mod:`.reader` -- :class:`BagReader`: topics, counts, time range, metadata, configuration,
  messages, numpy series;
* :mod:`.integrity` -- one streaming pass checking the data against CRCs, indexes, statistics,
  records and schemas (``BagReader(path, integrity=True)``; exit status 4);
* :mod:`.summary` -- what a file holds from its summary section alone (``rotor-avc bag info``);
* :mod:`.recover` -- :func:`recover_bag`: a new bag of every intact chunk (a killed recording,
  a damaged file);
* :mod:`.check` -- the ``ros2 bag`` / Foxglove / PlotJuggler pitfalls of a file or a rosbag2
  directory (``rotor-avc bag check``);
* :mod:`.msgdefs`, :mod:`.cdr`, :mod:`.mcap_writer`, :mod:`.metadata`, :mod:`.records` -- the
  format's parts.
"""
from .errors import BagError
from .reader import BagReader, TopicSeries
from .recover import recover_bag
from .topics import Stream
from .writer import BagWriter, write_bag

__all__ = ["BagError", "BagReader", "BagWriter", "Stream", "TopicSeries", "recover_bag",
           "write_bag"]
