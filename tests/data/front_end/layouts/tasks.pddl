(define (domain mailroom-tasks)
  (:requirements :typing)
  (:action deliver :parameters (?d - desk ?l - letter) :precondition (at ?l ?d) :effect (and)))
