"""The radar chain: ``simulate`` a plan's recording, ``process`` it into images and detections."""
