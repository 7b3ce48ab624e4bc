; file(?d): some paper in the tray of desk ?d ("all" desks: corner desks included).
(define (domain office-tasks)
  (:requirements :typing :existential-preconditions)
  (:action file
    :parameters (?d - desk ?p - paper)
    :precondition (at ?p ?d)
    :effect (and)))
