"""The contact transcription: collision sub-nodes, gaps, impulses and the impact law as element functions and rows."""
