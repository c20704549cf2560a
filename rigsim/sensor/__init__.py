"""Camera sensor pipeline: SpectralImage → electrons → raw → demosaic → white balance → sRGB.

Public API::

    from rigsim.sensor import load_sensor, Exposure, Lens, capture, develop, auto_exposure
    sensor = load_sensor("sony_ilce-7rm2")
    cap = capture(spectral_image, sensor, Exposure(1/125, 400, Lens(f_number=5.6)), seed=0)
    save_dng(cap, "raw.dng"); cap2 = develop(read_raw("photo.ARW"), DevelopOptions(white_balance="as_shot"))

See the modules: :mod:`~rigsim.sensor.model` (sensor files), :mod:`~rigsim.sensor.optics`
(camera equation), :mod:`~rigsim.sensor.noise` (EMVA 1288), :mod:`~rigsim.sensor.cfa`,
:mod:`~rigsim.sensor.demosaic`, :mod:`~rigsim.sensor.white_balance`, :mod:`~rigsim.sensor.ccm`,
:mod:`~rigsim.sensor.pipeline`, :mod:`~rigsim.sensor.photograph` (expose + capture + develop with
the designer's and the studies' fallbacks), :mod:`~rigsim.sensor.dng`, :mod:`~rigsim.sensor.raw_io`.
"""

from rigsim.sensor.ccm import ccm_ColorChecker, delta_E_ColorChecker
from rigsim.sensor.demosaic import DEMOSAICING_METHODS, demosaic
from rigsim.sensor.model import IsoSetting, Sensor, available_sensors, load_sensor, load_sensor_file
from rigsim.sensor.noise import NoiseSwitches
from rigsim.sensor.optics import Lens
from rigsim.sensor.pipeline import (Capture, DevelopOptions, Exposure, auto_exposure, capture, develop,
                                    mean_electrons_rgb)
from rigsim.sensor.raw_io import read_raw, save_capture, save_dng
from rigsim.sensor.white_balance import WHITE_BALANCE_METHODS, white_balance_gains

__all__ = ["Capture", "DEMOSAICING_METHODS", "DevelopOptions", "Exposure", "IsoSetting", "Lens",
           "NoiseSwitches", "Sensor", "WHITE_BALANCE_METHODS", "auto_exposure", "available_sensors",
           "capture", "ccm_ColorChecker", "delta_E_ColorChecker", "demosaic", "develop", "load_sensor",
           "load_sensor_file", "mean_electrons_rgb", "read_raw", "save_capture", "save_dng",
           "white_balance_gains"]
