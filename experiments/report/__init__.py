"""The reproduction report (`python -m experiments.reproduce`), in the order a report is built: `specs` names
every row's runs, files and commands and the thesis's figures; `data` reads the results files behind a row;
`tables`, `figures` and `reference` render them; `provenance` gives each report's header and closing
sections; `thesis` assembles the restaurant's report, `domain` any other domain folder's."""
