"""agnav drivers: NMEA/UBX GNSS, ADC analog sensors, bag player/recorder, tractor simulator."""
