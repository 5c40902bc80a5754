"""The inchworm mirror mount inside an optical instrument.

A Cassegrain telescope (`telescope`) whose secondary mirror sits on the three inchworm
actuators of `MirrorMount.ssp`. The mount's piston, tip and tilt, run through the FMUs by
FMPy (`cosim`), become the secondary's wavefront error (`telescope`: despace is focus, tilt
doubles on reflection); poppy's matrix Fourier transform turns each 2 ms sample into the PSF
on the detector and frames integrate every sample of their exposure (`optics`); a
fine-guidance loop closes the centroid onto the mount's tip/tilt references (`guidance`);
`scenario` runs the cases, `figures` draws them, `__main__` is the CLI.
"""
