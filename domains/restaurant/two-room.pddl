;; The two-room restaurant: countertop, coffeemachine, dishwasher, shelf, servingtable, fountain. The jar starts at shelf, empty.
;; Objects are listed in the order of shared/restaurant.md: a task consumes the
;; first matching object in this order. Move costs are 25 x hops.
(define (problem restaurant-two-room)
  (:domain restaurant)
  (:objects
    countertop coffeemachine dishwasher shelf servingtable fountain - location
    bowls knives - kind
    cup_0 cup_1 - cup
    water_fountain - watersource
    water_machine - machinewater
    apple_0 - apple
    bowl_0 - bowl
    knife_0 - knife
    jar_0 - jar
    plate_0 - plate)
  (:init
    (robot-at countertop) (hand-free)
    (at cup_0 countertop)
    (at cup_1 dishwasher) (dirty cup_1)
    (at water_fountain fountain)
    (at water_machine coffeemachine)
    (at apple_0 countertop)
    (at bowl_0 countertop)
    (at knife_0 countertop)
    (at jar_0 shelf)
    (at plate_0 servingtable)
    (kind-of bowl_0 bowls) (kind-of knife_0 knives)
    (washing-place dishwasher) (cutting-place countertop) (wash-ready countertop)
    (brews-at water_machine coffeemachine)
    (= (total-cost) 0)
    (= (move-cost countertop coffeemachine) 25) (= (move-cost countertop dishwasher) 50) (= (move-cost countertop shelf) 25) (= (move-cost countertop servingtable) 200) (= (move-cost countertop fountain) 225)
    (= (move-cost coffeemachine countertop) 25) (= (move-cost coffeemachine dishwasher) 25) (= (move-cost coffeemachine shelf) 50) (= (move-cost coffeemachine servingtable) 175) (= (move-cost coffeemachine fountain) 200)
    (= (move-cost dishwasher countertop) 50) (= (move-cost dishwasher coffeemachine) 25) (= (move-cost dishwasher shelf) 75) (= (move-cost dishwasher servingtable) 200) (= (move-cost dishwasher fountain) 225)
    (= (move-cost shelf countertop) 25) (= (move-cost shelf coffeemachine) 50) (= (move-cost shelf dishwasher) 75) (= (move-cost shelf servingtable) 175) (= (move-cost shelf fountain) 200)
    (= (move-cost servingtable countertop) 200) (= (move-cost servingtable coffeemachine) 175) (= (move-cost servingtable dishwasher) 200) (= (move-cost servingtable shelf) 175) (= (move-cost servingtable fountain) 50)
    (= (move-cost fountain countertop) 225) (= (move-cost fountain coffeemachine) 200) (= (move-cost fountain dishwasher) 225) (= (move-cost fountain shelf) 200) (= (move-cost fountain servingtable) 50))
  ;; A layout's own goal: serve water at the serving table (1,475 from here).
  (:goal (exists (?c - cup) (and (at ?c servingtable) (has-water ?c))))
  (:metric minimize (total-cost)))
