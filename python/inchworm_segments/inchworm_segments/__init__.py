"""A segmented telescope whose hexagonal segments each sit on a mount of three inchworms,
seen by a coronagraph.

Every segment's pose (piston, tip, tilt) at every 2 ms sample goes through hcipy's
segmented aperture and segmented mirror (`optics`) to the co-phasing error, the wavefront
error, the Strehl ratio and a perfect coronagraph's image; frames integrate every sample
of their exposure and run in parallel, bit-identical to serial (`frames`). `config` holds
the telescope's parameters and closed forms and the accepted range of every input,
`poses` the input CSV, the poses' check and a seeded synthetic run, `files` the bounded
reading of the CSVs, `figures` the PNGs and CSVs, `__main__` the command
(docs/segments.md).
"""
