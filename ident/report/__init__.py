"""The lab report: per-run analysis (pure), figures by the lab's rules, records, and the
Markdown + HTML report of the three lab cases (`ident report RUN... -o DIR`)."""
